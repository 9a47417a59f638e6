def stack_tower(env, task, base="red", middle="green", top="blue"):
    """Stack `middle` on `base`, then `top` on `middle`, where `base` stands."""
    base_pos = task.get_object_position(base)
    middle_pos = task.get_object_position(middle)
    top_pos = task.get_object_position(top)
    open_gripper(env, task)
    pick(env, task, target_pos=middle_pos, approach_axis="z")
    place(env, task, target_pos=[base_pos[0], base_pos[1], base_pos[2] + 0.05], approach_axis="z")
    pick(env, task, target_pos=top_pos, approach_axis="z")
    place(env, task, target_pos=[base_pos[0], base_pos[1], base_pos[2] + 0.095], approach_axis="z")
