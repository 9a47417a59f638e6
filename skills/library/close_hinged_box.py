def close_hinged_box(env, task, box="box"):
    """Push the open lid from behind with the open hand, past upright, so it falls shut."""
    base = task.get_object_position(box)
    hinge = [base[0] + 0.07, base[1], base[2] + 0.08]
    open_gripper(env, task)
    move_to_position(env, task, pos=[hinge[0] + 0.09, hinge[1], hinge[2] + 0.18])
    move_to_position(env, task, pos=[hinge[0] + 0.09, hinge[1], hinge[2] + 0.08])
    move_to_position(env, task, pos=[hinge[0] - 0.08, hinge[1], hinge[2] + 0.08])
    move_to_position(env, task, pos=[hinge[0] - 0.08, hinge[1], hinge[2] + 0.18])
