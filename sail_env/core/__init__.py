"""The model-agnostic episode machinery (numpy only): one batched core that the single and the
vector environments are both views of, and the task specification controllers design on."""

from sail_env.core.delay import delay_steps
from sail_env.core.episode import EpisodeCore, StepResult
from sail_env.core.spec import Disturbances, EpisodeSpec

__all__ = ["Disturbances", "EpisodeCore", "EpisodeSpec", "StepResult", "delay_steps"]
