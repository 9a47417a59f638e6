def put_in_drawer(env, task, obj="cube", drawer="drawer"):
    """Pick `obj`, carry it high over the cabinet's front, and set it down in the front part of the
    open drawer's tray."""
    obj_pos = task.get_object_position(obj)
    knob = task.get_object_position(drawer)
    open_gripper(env, task)
    pick(env, task, obj_name=obj)
    move_to_position(env, task, pos=[obj_pos[0], obj_pos[1], knob[2] + 0.15])
    move_to_position(env, task, pos=[knob[0] + 0.07, knob[1], knob[2] + 0.15])
    move_to_position(env, task, pos=[knob[0] + 0.07, knob[1], knob[2] - 0.015])
    open_gripper(env, task)
    move_to_position(env, task, pos=[knob[0] + 0.07, knob[1], knob[2] + 0.15])
