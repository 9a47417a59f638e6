def stack_tower(env, task, base="red", middle="green", top="blue"):
    """Stack `middle` on `base`, then `top` on `middle`, where `base` stands."""
    open_gripper(env, task)
    pick(env, task, obj_name=middle)
    place(env, task, obj_name=base)
    pick(env, task, obj_name=top)
    place(env, task, obj_name=middle)
