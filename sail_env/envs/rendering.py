"""Frames of a planar episode: the sail on its beam, and the trajectory so far."""

from __future__ import annotations

import numpy as np

from sail_env.physics.config import SailConfig
from sail_env.physics.planar import OMEGA, THETA, VX, X
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD

FRAME_SIZE_IN = (8.0, 4.0)
FRAME_DPI = 80


class SailRenderer:
    """Draws with matplotlib; ``rgb_array`` frames are off-screen (Agg), ``human`` opens a window."""

    def __init__(self, render_mode: str, fps: int) -> None:
        import matplotlib

        if render_mode == "rgb_array":
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            self.figure = Figure(figsize=FRAME_SIZE_IN, dpi=FRAME_DPI)
            FigureCanvasAgg(self.figure)
        else:
            import matplotlib.pyplot as plt

            matplotlib.interactive(True)
            self.figure = plt.figure(figsize=FRAME_SIZE_IN, dpi=FRAME_DPI)
        self.render_mode = render_mode
        self.pause_s = 1.0 / fps

    def draw(self, config: SailConfig, trajectory: list[tuple[float, np.ndarray, np.ndarray]],
             cutoff_s: float, action_scale: np.ndarray) -> np.ndarray | None:
        fig = self.figure
        fig.clear()
        sail_ax, track_ax = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1, 1.4]})
        t, state, beam_input = trajectory[-1]
        self._draw_sail(sail_ax, config, state, beam_input, action_scale)
        times = np.array([p[0] for p in trajectory])
        states = np.array([p[1] for p in trajectory])
        vz = config.axial_acceleration_m_s2 * cutoff_s
        track_ax.semilogy(times, np.maximum(np.abs(states[:, VX]) / vz, 1e-13), lw=1, label="|V⊥|/Vz")
        track_ax.axhline(POINTING_TOLERANCE_RAD, color="tab:red", ls="--", lw=1, label="10 nrad")
        track_ax.set_xlabel("flight time [s]")
        track_ax.set_ylabel("flight direction if cut now [rad]")
        track_ax.set_ylim(1e-12, 1e-5)
        track_ax.legend(loc="upper right", fontsize=8)
        track_ax.set_title(f"t = {t:.3f} s,  X = {state[X] * 1e3:+.2f} mm,  θ = {state[THETA] * 1e3:+.3f} mrad,"
                           f"  ω = {state[OMEGA]:+.1e}", fontsize=8)
        fig.tight_layout()
        fig.canvas.draw()
        if self.render_mode == "human":
            import matplotlib.pyplot as plt

            plt.pause(self.pause_s)
            return None
        return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()

    @staticmethod
    def _draw_sail(ax, config: SailConfig, state: np.ndarray, beam_input: np.ndarray,
                   action_scale: np.ndarray) -> None:
        """The sail, struts and payload around the CoM, lateral motion exaggerated to be seen."""
        a, lc, strut = config.aperture_radius_m, config.com_distance_m, config.strut_length_m
        exaggerate_x = 0.25 * a / max(2e-2, abs(state[X]), action_scale[0])
        exaggerate_theta = 0.2 / max(2e-3, abs(state[THETA]), action_scale[1])
        x0, theta = state[X] * exaggerate_x, state[THETA] * exaggerate_theta
        axis = np.array([np.sin(theta), np.cos(theta)])  # (lateral, along the beam)
        side = np.array([np.cos(theta), -np.sin(theta)])
        com = np.array([x0, 0.0])
        vertex = com + lc * axis
        r = config.curvature_radius_m
        s = np.linspace(-a, a, 41)
        sag = 0.0 if np.isinf(r) else r - np.sqrt(r**2 - s**2)
        sail = vertex + np.outer(s, side) - np.outer(sag, axis)
        payload = com - (strut - lc) * axis
        beam_x = beam_input[0] * exaggerate_x
        ax.axvspan(beam_x - a, beam_x + a, color="gold", alpha=0.25, lw=0)
        ax.axvline(0.0, color="grey", lw=0.8, ls=":")
        ax.plot(sail[:, 0], sail[:, 1], color="tab:blue", lw=2)
        for end in (sail[0], sail[-1]):
            ax.plot([end[0], payload[0]], [end[1], payload[1]], color="0.4", lw=0.8)
        ax.plot(*payload, "s", color="k", ms=5)
        ax.plot(*com, "o", color="tab:orange", ms=4)
        ax.set_xlim(-2 * a, 2 * a)
        ax.set_ylim(-(strut - lc) - 2, lc + 2)
        ax.set_aspect("equal")
        ax.set_title("sail on its beam (lateral motion exaggerated)", fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])

    def close(self) -> None:
        if self.render_mode == "human":
            import matplotlib.pyplot as plt

            plt.close(self.figure)
