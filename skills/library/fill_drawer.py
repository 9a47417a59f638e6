def fill_drawer(env, task, first="cube", second="green", drawer="drawer"):
    """Put two objects into the open drawer, one behind the other where the tray is out (fingers
    close across the tray: side by side they would catch its walls)."""
    knob = task.get_object_position(drawer)
    opening = task.get_object_state(drawer)
    for name, depth in [[first, 0.062], [second, opening - 0.005]]:
        obj_pos = task.get_object_position(name)
        open_gripper(env, task)
        move_to_position(env, task, pos=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.12])
        pick(env, task, obj_name=name)
        move_to_position(env, task, pos=[obj_pos[0], obj_pos[1], knob[2] + 0.15])
        move_to_position(env, task, pos=[knob[0] + depth, knob[1], knob[2] + 0.15])
        move_to_position(env, task, pos=[knob[0] + depth, knob[1], knob[2] - 0.015])
        open_gripper(env, task)
        move_to_position(env, task, pos=[knob[0] + depth, knob[1], knob[2] + 0.15])
