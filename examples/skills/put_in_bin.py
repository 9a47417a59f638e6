def put_in_bin(env, task, obj="cube", receptacle="bin"):
    """Drop `obj` into `receptacle` a little towards where it came from, off the far wall (Panda, parallel-jaw hand)."""
    obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position(receptacle)
    open_gripper(env, task)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    near_side = [
        bin_pos[0] + 0.1 * (obj_pos[0] - bin_pos[0]),
        bin_pos[1] + 0.1 * (obj_pos[1] - bin_pos[1]),
        bin_pos[2] + 0.1,
    ]
    place(env, task, target_pos=near_side, approach_axis="z")
