def move_to_region(env, task, obj="cube", region="zone"):
    """Pick `obj` up and set it down in the middle of `region`, carried high over whatever lies between."""
    obj_pos = task.get_object_position(obj)
    region_pos = task.get_object_position(region)
    open_gripper(env, task)
    move(env, task, target_pos=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.12], timeout=6.0)
    pick(env, task, target_pos=obj_pos, approach_axis="z")
    move(env, task, target_pos=[obj_pos[0], obj_pos[1], obj_pos[2] + 0.15], timeout=6.0)
    move(env, task, target_pos=[region_pos[0], region_pos[1], obj_pos[2] + 0.15], timeout=6.0)
    place(env, task, target_pos=[region_pos[0], region_pos[1], obj_pos[2] + 0.002], approach_axis="z")
    move(env, task, target_pos=[region_pos[0], region_pos[1], obj_pos[2] + 0.15], timeout=6.0)
