def press_button(env, task, button="button"):
    """Press the button's cap down with the closed fingertips, then let it spring back."""
    cap_pos = task.get_object_position(button)
    close_gripper(env, task)
    move(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.08], timeout=6.0)
    move(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.010], timeout=3.0)
    move(env, task, target_pos=[cap_pos[0], cap_pos[1], cap_pos[2] + 0.08], timeout=3.0)
