def open_drawer(env, task, drawer="drawer"):
    """Grip the drawer's knob from above, pull it 12 cm towards the robot, and let go.
    The pull runs 5 mm above the knob's read height: pressing down binds the drawer's slide."""
    knob = task.get_object_position(drawer)
    open_gripper(env, task)
    move(env, task, target_pos=[knob[0], knob[1], knob[2] + 0.08], timeout=6.0)
    move(env, task, target_pos=knob, timeout=3.0)
    close_gripper(env, task)
    move(env, task, target_pos=[knob[0] - 0.12, knob[1], knob[2] + 0.005], timeout=6.0)
    open_gripper(env, task)
    move(env, task, target_pos=[knob[0] - 0.12, knob[1], knob[2] + 0.08], timeout=3.0)
