def drag_with_tool(env, task, obj="cube", tool="rake", region="zone"):
    """Take the rake by its handle, lower its crossbar just beyond the far object, and drag the
    object back into the region (the crossbar sits 0.13 m ahead of the grip); put the rake back."""
    tool_pos = task.get_object_position(tool)
    obj_pos = task.get_object_position(obj)
    region_pos = task.get_object_position(region)
    grip_z = tool_pos[2] + 0.025
    open_gripper(env, task)
    pick(env, task, target_pos=[tool_pos[0], tool_pos[1], grip_z], approach_axis="z")
    move(env, task, target_pos=[obj_pos[0] + 0.06 - 0.13, obj_pos[1], grip_z + 0.08], timeout=6.0)
    move(env, task, target_pos=[obj_pos[0] + 0.06 - 0.13, obj_pos[1], grip_z + 0.004], timeout=4.0)
    move(env, task, target_pos=[region_pos[0] + 0.033 - 0.13, obj_pos[1], grip_z + 0.004], timeout=8.0)
    move(env, task, target_pos=[region_pos[0] + 0.033 - 0.13, obj_pos[1], grip_z + 0.08], timeout=4.0)
    place(env, task, target_pos=[tool_pos[0], tool_pos[1], grip_z + 0.004], approach_axis="z")
