"""The model-agnostic episode machinery (numpy only): one batched core that the single and the
vector environments are both views of, the task specification controllers design on, and the
plant contract, the one interface through which they see a sail model."""

from sail_env.core.delay import delay_steps
from sail_env.core.episode import EpisodeCore, StepResult
from sail_env.core.plant import Plant
from sail_env.core.spec import EpisodeSpec
from sail_env.physics.randomisation import Randomisation

__all__ = ["EpisodeCore", "EpisodeSpec", "Plant", "Randomisation", "StepResult", "delay_steps"]
