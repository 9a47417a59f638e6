def pick_and_lift(env, task, obj="cube"):
    """Grasp `obj` from above and hold it up (Panda, parallel-jaw hand)."""
    obj_pos = task.get_object_position(obj)
    open_gripper(env, task)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    lift_pos = [obj_pos[0], obj_pos[1], obj_pos[2] + 0.15]
    move(env, task, target_pos=lift_pos, timeout=4.0)
