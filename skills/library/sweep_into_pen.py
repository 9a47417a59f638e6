def sweep_into_pen(env, task, first="red", second="blue", pen="pen"):
    """Push each object along the table through the pen's open side until it is inside."""
    pen_pos = task.get_object_position(pen)
    for name in [first, second]:
        obj_pos = task.get_object_position(name)
        start = [obj_pos[0] - 0.06, obj_pos[1], obj_pos[2]]
        goal = [pen_pos[0], obj_pos[1], obj_pos[2]]
        push(env, task, start_pos=start, target_pos=goal, approach_axis="z")
