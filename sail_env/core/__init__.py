"""The model-agnostic episode machinery (numpy only): one batched core that the single and the
vector environments are both views of, the task specification controllers design on, and the
plant contract, the one interface through which they see a sail model."""

from sail_env.core.delay import delay_steps
from sail_env.core.episode import EpisodeCore, StepResult
from sail_env.core.plant import Plant
from sail_env.core.spec import Disturbances, EpisodeSpec

__all__ = ["Disturbances", "EpisodeCore", "EpisodeSpec", "Plant", "StepResult", "delay_steps"]
