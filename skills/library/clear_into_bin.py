def clear_into_bin(env, task, first="cube", second="block", third="can", fourth="dice", receptacle="bin"):
    """Put four objects into the bin, one per corner, none on another: each carried high before the
    arm swings over the bin, the hand rising out of it before the next."""
    bin_pos = task.get_object_position(receptacle)
    for name, dx, dy in [
        [first, -0.045, -0.045],
        [second, -0.045, 0.045],
        [third, 0.045, -0.045],
        [fourth, 0.045, 0.045],
    ]:
        obj_pos = task.get_object_position(name)
        open_gripper(env, task)
        move(env, task, target_pos=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.12], timeout=6.0)
        pick(env, task, target_pos=obj_pos, approach_axis="z")
        move(env, task, target_pos=[obj_pos[0], obj_pos[1], bin_pos[2] + 0.2], timeout=6.0)
        move(env, task, target_pos=[bin_pos[0] + dx, bin_pos[1] + dy, bin_pos[2] + 0.2], timeout=6.0)
        place(env, task, target_pos=[bin_pos[0] + dx, bin_pos[1] + dy, bin_pos[2] + 0.005], approach_axis="z")
        move(env, task, target_pos=[bin_pos[0] + dx, bin_pos[1] + dy, bin_pos[2] + 0.2], timeout=6.0)
