def put_in_bin(env, task, obj="cube", receptacle="bin"):
    """Pick `obj` from the table and drop it into the open `receptacle` (Panda, parallel-jaw hand)."""
    obj_pos = task.get_object_position(obj)
    bin_pos = task.get_object_position(receptacle)
    open_gripper(env, task)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    drop_pos = [bin_pos[0], bin_pos[1], bin_pos[2] + 0.1]
    place(env, task, target_pos=drop_pos, approach_axis="z")
