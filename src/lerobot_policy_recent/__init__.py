"""RECENT for LeRobot: the one import namespace of the ``lerobot_policy_recent`` distribution.

Its subpackages are the repository's top-level folders: ``lerobot_policy_recent.recent_plugin``
(the policy: grounding, infillers, executor), ``.evaluation`` (the benchmark harness),
``.descriptions`` (robot descriptions: data), ``.ontology``, ``.skills``, ``.robosuite_envs``,
``.logs`` and ``.scripts``. In the checkout this package is ``src/lerobot_policy_recent``, whose
subpackages are relative links to those folders: static analysers, IDEs and the build backend
follow them like any directory, and an editable install puts only ``src`` on ``sys.path``, so no
project module is importable under a second, top-level name.

LeRobot imports every installed distribution whose name starts with ``lerobot_policy_`` by that
exact name, with ``lerobot`` already loaded: that import registers policy type ``recent`` and env
type ``recent``. Without ``lerobot`` loaded (the ``recent`` CLI, the LM worker, a reader of the
logs), importing a subpackage does not pull in LeRobot and torch (about 12 s); the policy classes
load, and register, on first use of ``lerobot_policy_recent.RecentConfig`` and its siblings.
"""

import sys

POLICY_EXPORTS = ("RecentConfig", "RecentPolicy", "make_recent_pre_post_processors")
__all__ = list(POLICY_EXPORTS)


def register_with_lerobot() -> None:
    """Import the policy and env configs, which registers ``--policy.type=recent`` and ``--env.type=recent``."""
    # the benchmark harness's methods (--policy.method.type=cap, an ablation): they need none of its extra
    from lerobot_policy_recent.evaluation import methods  # noqa: F401
    from lerobot_policy_recent.recent_plugin.configuration_recent import RecentConfig
    from lerobot_policy_recent.recent_plugin.modeling_recent import RecentPolicy
    from lerobot_policy_recent.recent_plugin.processor_recent import make_recent_pre_post_processors
    from lerobot_policy_recent.robosuite_envs import lerobot_env  # noqa: F401  (EnvConfig "recent")

    globals().update(
        RecentConfig=RecentConfig,
        RecentPolicy=RecentPolicy,
        make_recent_pre_post_processors=make_recent_pre_post_processors,
    )


def __getattr__(name: str):
    if name in POLICY_EXPORTS:
        register_with_lerobot()
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if "lerobot" in sys.modules:  # LeRobot's plugin discovery (or a user's LeRobot script) is importing us
    register_with_lerobot()
