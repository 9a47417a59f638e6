def sweep_into_pen(env, task, first="red", second="blue", pen="pen"):
    """Push each object through the pen's open side with the closed hand, aiming at a point of the
    mouth it fits through, a little below its centre so the hand does not ride up over it."""
    pen_pos = task.get_object_position(pen)
    close_gripper(env, task)
    for name in [first, second]:
        obj_pos = task.get_object_position(name)
        lane = min(max(obj_pos[1], pen_pos[1] - 0.03), pen_pos[1] + 0.03)
        dx = pen_pos[0] - obj_pos[0]
        dy = lane - obj_pos[1]
        start = [obj_pos[0] - 0.06, obj_pos[1] - 0.06 * dy / dx, obj_pos[2] - 0.005]
        move_to_position(env, task, pos=[start[0], start[1], start[2] + 0.1])
        move_to_position(env, task, pos=start)
        move_to_position(env, task, pos=[pen_pos[0], lane, obj_pos[2] - 0.005])
        move_to_position(env, task, pos=[pen_pos[0], lane, obj_pos[2] + 0.1])
