"""Baselines and learners for lightsail-gym, behind one interface (:class:`Agent`)."""

from agents.base import Agent
from agents.lqg import LQGAgent
from agents.lqr import LQRAgent, lqr_gain
from agents.passive import PassiveAgent

__all__ = ["Agent", "LQGAgent", "LQRAgent", "PassiveAgent", "lqr_gain"]
