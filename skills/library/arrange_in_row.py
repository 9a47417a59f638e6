def arrange_in_row(env, task, first="red", second="green", third="blue", row="row"):
    """Place three objects on the row's slots, 10 cm apart, so that none touches another."""
    row_pos = task.get_object_position(row)
    open_gripper(env, task)
    for name, dy in [[first, -0.1], [second, 0.0], [third, 0.1]]:
        obj_pos = task.get_object_position(name)
        pick(env, task, obj_name=name)
        move_to_position(env, task, pos=[row_pos[0], row_pos[1] + dy, obj_pos[2] + 0.052])
        move_to_position(env, task, pos=[row_pos[0], row_pos[1] + dy, obj_pos[2] + 0.002])
        open_gripper(env, task)
        move_to_position(env, task, pos=[row_pos[0], row_pos[1] + dy, obj_pos[2] + 0.052])
