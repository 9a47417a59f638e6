def put_in_drawer(env, task, obj="cube", drawer="drawer"):
    """Pick `obj` and set it down in the front part of the open drawer's tray."""
    obj_pos = task.get_object_position(obj)
    knob = task.get_object_position(drawer)
    open_gripper(env, task)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    place(env, task, target_pos=[knob[0] + 0.07, knob[1], knob[2] - 0.015], approach_axis="z")
