def place_on_plate(env, task, obj="cube", target="plate"):
    """Pick `obj` and set it down on the middle of the plate `target`."""
    obj_pos = task.get_object_position(obj)
    plate_pos = task.get_object_position(target)
    open_gripper(env, task)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    drop_pos = [plate_pos[0], plate_pos[1], plate_pos[2] + 0.035]
    place(env, task, target_pos=drop_pos, approach_axis="z")
