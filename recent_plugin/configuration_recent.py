"""``RecentConfig``: the LeRobot policy config of RECENT (``--policy.type=recent``)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from lerobot.configs import NormalizationMode, PreTrainedConfig
from lerobot.optim import AdamConfig

from lerobot_policy_recent.recent_plugin.settings import RecentSettings


@PreTrainedConfig.register_subclass("recent")
@dataclass
class RecentConfig(PreTrainedConfig, RecentSettings):
    """Grounds Panda reference skills onto the env's robot and executes them; nothing is trained.

    The fields of :class:`RecentSettings` (``--policy.infiller.type=rule``, ``--policy.method.type=cap``,
    ``--policy.max_retries=3``, ...) are the ``recent`` CLI's options, declared once there; this
    class adds what LeRobot's policy interface and the logs need.
    """

    log_dir: str | None = "outputs/recent_logs"  # MCAP + Rerun + LeRobotDataset per episode; None: no logs
    log_sinks: str = "mcap,rerun,dataset"  # comma list of the sinks to write
    device: str | None = "cpu"
    normalization_mapping: dict[str, NormalizationMode] = field(
        default_factory=lambda: {
            "STATE": NormalizationMode.IDENTITY,
            "ENV": NormalizationMode.IDENTITY,
            "ACTION": NormalizationMode.IDENTITY,
            "VISUAL": NormalizationMode.IDENTITY,
        }
    )

    def __post_init__(self):
        super().__post_init__()  # LeRobot's (PreTrainedConfig comes first in the MRO)
        RecentSettings.__post_init__(self)

    def agent_settings(self) -> RecentSettings:
        """The settings tree alone (without LeRobot's fields), as the agent takes it."""
        return RecentSettings(**{f.name: getattr(self, f.name) for f in fields(RecentSettings)})

    @property
    def observation_delta_indices(self) -> None:
        return None

    @property
    def action_delta_indices(self) -> None:
        return None

    @property
    def reward_delta_indices(self) -> None:
        return None

    def get_optimizer_preset(self) -> AdamConfig:
        return AdamConfig(lr=0.0)

    def get_scheduler_preset(self) -> None:
        return None

    def validate_features(self) -> None:
        from lerobot.utils.constants import OBS_ENV_STATE, OBS_STATE

        missing = [k for k in (OBS_STATE, OBS_ENV_STATE) if k not in (self.input_features or {})]
        if missing:
            raise ValueError(
                f"RECENT needs {', '.join(missing)} among the input features (use --env.type=recent); got {sorted(self.input_features or {})}"
            )
