def fill_box(env, task, obj="blue", box="box"):
    """Carry `obj` high over the open box's walls, lower it onto the box's floor, and rise clear."""
    obj_pos = task.get_object_position(obj)
    base = task.get_object_position(box)
    open_gripper(env, task)
    move_to_position(env, task, pos=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.12])
    pick(env, task, obj_name=obj)
    move_to_position(env, task, pos=[obj_pos[0], obj_pos[1], base[2] + 0.2])
    move_to_position(env, task, pos=[base[0], base[1], base[2] + 0.2])
    place(env, task, obj_name=box)
    move_to_position(env, task, pos=[base[0], base[1], base[2] + 0.2])
