def insert_peg(env, task, peg="peg", hole="hole"):
    """Pick the peg, hold it high above the hole, and lower it in before letting go."""
    peg_pos = task.get_object_position(peg)
    hole_pos = task.get_object_position(hole)
    open_gripper(env, task)
    pick(env, task, target_pos=peg_pos, approach_axis="z")
    move(env, task, target_pos=[hole_pos[0], hole_pos[1], hole_pos[2] + 0.16], timeout=6.0)
    place(env, task, target_pos=[hole_pos[0], hole_pos[1], hole_pos[2] + 0.065], approach_axis="z")
