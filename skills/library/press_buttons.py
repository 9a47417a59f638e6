def press_buttons(env, task, first="power", second="channel", third="volume"):
    """Press three buttons in turn with the closed fingertips: over each cap, down onto it, and up again."""
    close_gripper(env, task)
    for button in [first, second, third]:
        cap_pos = task.get_object_position(button)
        move(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.08], timeout=6.0)
        move(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.010], timeout=3.0)
        move(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.08], timeout=3.0)
