def close_drawer(env, task, drawer="drawer"):
    """Push the open drawer shut by its knob with the closed hand: down on the robot's side of the
    knob, then along the slide to 12 mm short of where the knob sits when the drawer is shut."""
    knob = task.get_object_position(drawer)
    opening = task.get_object_state(drawer)
    close_gripper(env, task)
    move_to_position(env, task, pos=[knob[0] - 0.035, knob[1], knob[2] + 0.1])
    move_to_position(env, task, pos=[knob[0] - 0.035, knob[1], knob[2]])
    move_to_position(env, task, pos=[knob[0] + opening - 0.012, knob[1], knob[2]])
    move_to_position(env, task, pos=[knob[0] + opening - 0.012, knob[1], knob[2] + 0.1])
