def close_drawer(env, task, drawer="drawer"):
    """Push the open drawer shut by its knob with the closed hand."""
    knob = task.get_object_position(drawer)
    opening = task.get_object_state(drawer)
    start = [knob[0] - 0.035, knob[1], knob[2]]
    goal = [knob[0] + opening - 0.012, knob[1], knob[2]]
    push(env, task, start_pos=start, target_pos=goal, approach_axis="z")
