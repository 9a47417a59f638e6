def fill_box(env, task, obj="blue", box="box"):
    """Carry `obj` high over the open box's walls, lower it onto the box's floor, and rise clear."""
    obj_pos = task.get_object_position(obj)
    base = task.get_object_position(box)
    open_gripper(env, task)
    move(env, task, target_pos=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.12], timeout=6.0)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    move(env, task, target_pos=[obj_pos[0], obj_pos[1], base[2] + 0.2], timeout=6.0)
    move(env, task, target_pos=[base[0], base[1], base[2] + 0.2], timeout=6.0)
    place(env, task, target_pos=[base[0], base[1], base[2] + 0.035], approach_axis="z")
    move(env, task, target_pos=[base[0], base[1], base[2] + 0.2], timeout=6.0)
