def stack(env, task, obj="cube", target="block"):
    """Pick `obj` and set it down centred on top of the block `target`."""
    obj_pos = task.get_object_position(obj)
    base_pos = task.get_object_position(target)
    open_gripper(env, task)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    drop_pos = [base_pos[0], base_pos[1], base_pos[2] + 0.055]
    place(env, task, target_pos=drop_pos, approach_axis="z")
