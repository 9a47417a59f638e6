"""RECENT for LeRobot: the one import namespace of the ``lerobot_policy_recent`` distribution.

Its subpackages are the repository's top-level folders: ``lerobot_policy_recent.recent_plugin``
(the policy, grounding, infillers, evaluation), ``.ontology``, ``.skills``, ``.robosuite_envs``,
``.logs`` and ``.scripts``. The wheel maps those folders into this package (``pyproject.toml``);
in a source checkout (an editable install, the tests) they stay where the layout promises them,
and an import finder maps them in (nothing else of the checkout is reachable this way).

LeRobot imports every installed distribution whose name starts with ``lerobot_policy_`` by that
exact name, with ``lerobot`` already loaded: that import registers policy type ``recent`` and env
type ``recent``. Without ``lerobot`` loaded (the ``recent`` CLI, the LM worker, a reader of the
logs), importing a subpackage does not pull in LeRobot and torch (about 12 s); the policy classes
load, and register, on first use of ``lerobot_policy_recent.RecentConfig`` and its siblings.
"""

import importlib.abc
import importlib.util
import os
import sys

SUBPACKAGES = ("recent_plugin", "ontology", "skills", "robosuite_envs", "logs", "scripts")
POLICY_EXPORTS = ("RecentConfig", "RecentPolicy", "make_recent_pre_post_processors")
__all__ = list(POLICY_EXPORTS)


class _CheckoutSubpackages(importlib.abc.MetaPathFinder):
    """In a source checkout, ``lerobot_policy_recent.<folder>`` is the repository's top-level ``<folder>``."""

    def __init__(self, root: str):
        self.root = root

    def find_spec(self, fullname, path=None, target=None):
        package, _, name = fullname.partition(".")
        if package != __name__ or name not in SUBPACKAGES:
            return None  # deeper modules resolve through the subpackage's own __path__
        folder = os.path.join(self.root, name)
        return importlib.util.spec_from_file_location(
            fullname, os.path.join(folder, "__init__.py"), submodule_search_locations=[folder]
        )


_checkout = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if os.path.isfile(os.path.join(_checkout, "pyproject.toml")) and all(
    os.path.isfile(os.path.join(_checkout, name, "__init__.py")) for name in SUBPACKAGES
):
    sys.meta_path.insert(0, _CheckoutSubpackages(_checkout))


def register_with_lerobot() -> None:
    """Import the policy and env configs, which registers ``--policy.type=recent`` and ``--env.type=recent``."""
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
