"""``RecentConfig``: the LeRobot policy config of RECENT (``--policy.type=recent``)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from lerobot.configs import NormalizationMode, PreTrainedConfig
from lerobot.optim import AdamConfig

from lerobot_policy_recent.recent_plugin.agent import MODES, AgentSettings
from lerobot_policy_recent.recent_plugin.infillers import BACKENDS


@PreTrainedConfig.register_subclass("recent")
@dataclass
class RecentConfig(PreTrainedConfig):
    """Grounds Panda reference skills onto the env's robot and executes them; nothing is trained.

    ``backend``: ``llamacpp`` (GGUF on CPU), ``transformers`` (a Hub id or local directory on
    ``lm_device``), ``openai`` (an OpenAI-compatible completions server at ``base_url``) or ``rule``
    (ontology substitution, no LM).
    ``model``: a known model name (``recent model list``) or a path to a ``.gguf`` file.
    """

    # Flat fields (``--policy.backend=rule``) with the agent's defaults, kept in one place.
    backend: str = AgentSettings.backend
    model: str = AgentSettings.model
    n_threads: int | None = AgentSettings.n_threads
    max_retries: int = AgentSettings.max_retries
    seed: int = AgentSettings.seed
    max_skill_steps: int = AgentSettings.max_skill_steps
    base_url: str | None = AgentSettings.base_url
    lm_device: str | None = AgentSettings.lm_device  # transformers backend: cuda | cpu
    lm_dtype: str = AgentSettings.lm_dtype
    lm_quantization: str | None = AgentSettings.lm_quantization  # 8bit | 4bit (CUDA)
    offline_validation: bool = AgentSettings.offline_validation  # False: serve unvalidated skills (ablation)
    skill_library: str | None = AgentSettings.skill_library  # your own skills directory (default: bundled)
    mode: str = (
        AgentSettings.mode
    )  # recent | name-similarity | full-regen | no-ontology (ablations) | cap | repair | agentless
    insitu: bool = AgentSettings.insitu  # False: no run-time checks, reactive repair only (ablation)
    max_repairs: int = AgentSettings.max_repairs
    fast_path: bool = AgentSettings.fast_path  # render fully decided spans without the LM
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
        super().__post_init__()
        if self.backend not in BACKENDS:
            raise ValueError(f"policy.backend={self.backend!r} is not known; choose one of: {', '.join(BACKENDS)}")
        if self.mode not in MODES:
            raise ValueError(f"policy.mode={self.mode!r} is not known; choose one of: {', '.join(MODES)}")
        if self.max_retries < 0:
            raise ValueError("policy.max_retries must be >= 0")

    def agent_settings(self) -> AgentSettings:
        return AgentSettings(**{f.name: getattr(self, f.name) for f in fields(AgentSettings)})

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
