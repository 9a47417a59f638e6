"""LeRobot plugin entry point: importing it registers policy type ``recent`` and env type ``recent``.

LeRobot imports every installed distribution whose name starts with ``lerobot_policy_`` by that
exact name, so this module is all the glue there is.
"""

import robosuite_envs.lerobot_env  # noqa: F401  (registers EnvConfig "recent")
from recent_plugin.configuration_recent import RecentConfig
from recent_plugin.modeling_recent import RecentPolicy
from recent_plugin.processor_recent import make_recent_pre_post_processors

__all__ = ["RecentConfig", "RecentPolicy", "make_recent_pre_post_processors"]
