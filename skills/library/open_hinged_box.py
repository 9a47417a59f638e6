def open_hinged_box(env, task, box="box"):
    """Grip the lid's knob and swing it up along the hinge's arc well past upright (a grip that lags
    behind the arc still leaves the lid past its balance point), let go, and back away over the hinge."""
    base = task.get_object_position(box)
    hinge = [base[0] + 0.07, base[1], base[2] + 0.08]
    knob = [hinge[0] - 0.125, hinge[1], hinge[2] + 0.022]
    open_gripper(env, task)
    move_to_position(env, task, pos=[knob[0], knob[1], knob[2] + 0.08])
    move_to_position(env, task, pos=knob)
    close_gripper(env, task)
    for offset in [[-0.110, 0.063], [-0.082, 0.097], [-0.043, 0.119], [0.0, 0.127], [0.044, 0.119], [0.078, 0.1]]:
        move_to_position(env, task, pos=[hinge[0] + offset[0], hinge[1], hinge[2] + offset[1]])
    open_gripper(env, task)
    move_to_position(env, task, pos=[hinge[0], hinge[1], hinge[2] + 0.2])
