def open_drawer(env, task, drawer="drawer"):
    """Grip the drawer's knob, pull it 12 cm towards the robot, and let go.
    The pull runs 5 mm above the knob's read height: pressing down binds the drawer's slide."""
    knob = task.get_object_position(drawer)
    grasp_handle(env, task, handle_name=drawer)
    move_to_position(env, task, pos=[knob[0] - 0.12, knob[1], knob[2] + 0.005])
    release_handle(env, task)
    move_to_position(env, task, pos=[knob[0] - 0.12, knob[1], knob[2] + 0.08])
