"""Frames of an episode: the sail on its beam, and the flight direction so far. A 3D sail is drawn
in both lateral planes side by side: x–z (its offset x, the tilt θy that moves it, the beam inputs on
x) and y–z (y, θx, whose positive sense tilts the sail towards −y, the beam inputs on y)."""

from __future__ import annotations

import numpy as np

from sail_env.core.spec import EpisodeSpec
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD

#: A frame with one sail panel (the planar model's); each further one (the 3D model's y–z plane) widens it.
FRAME_SIZE_IN = (8.0, 4.0)
SAIL_PANEL_WIDTH_IN = 2.0
FRAME_DPI = 80


class SailRenderer:
    """Draws off-screen with matplotlib (Agg): ``rgb_array`` frames. The env has no window of its own:
    ``gym.make(..., render_mode="human")`` shows these frames through Gymnasium's ``HumanRendering``
    wrapper (pygame), as for any env that declares ``rgb_array`` only."""

    def __init__(self, sail_panels: int = 1) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.figure = Figure(figsize=(FRAME_SIZE_IN[0] + (sail_panels - 1) * SAIL_PANEL_WIDTH_IN, FRAME_SIZE_IN[1]),
                             dpi=FRAME_DPI)
        FigureCanvasAgg(self.figure)

    def draw(self, spec: EpisodeSpec, trajectory: list[tuple[float, np.ndarray, np.ndarray]],
             speed_at_cutoff: float) -> np.ndarray:
        """A frame: the sail now, in each lateral plane (left), and its flight direction if the beam were
        cut, over the control window so far (right). ``trajectory`` holds ``(t, state, applied input)``
        per step."""
        views = axis_views(spec)
        fig = self.figure
        fig.clear()
        *sail_axes, track_ax = fig.subplots(1, len(views) + 1, gridspec_kw={"width_ratios": [1] * len(views) + [1.4]})
        t, state, beam_input = trajectory[-1]
        for ax, view in zip(sail_axes, views):
            self._draw_sail(ax, view, state, beam_input)
        times = np.array([p[0] for p in trajectory])
        pointing = np.array([np.hypot.reduce(p[1][views[0].velocities]) for p in trajectory]) / speed_at_cutoff
        track_ax.semilogy(times, np.maximum(pointing, 1e-13), lw=1, marker="o", markevery=[-1], ms=3,
                          label="|V⊥|/Vz")
        track_ax.axhline(POINTING_TOLERANCE_RAD, color="tab:red", ls="--", lw=1, label="10 nrad")
        start = spec.config.control_start_s
        track_ax.set_xlim(start, start + spec.n_steps * spec.dt)  # the whole window, from the first frame on
        track_ax.set_xlabel("flight time [s]")
        track_ax.set_ylabel("flight direction if cut now [rad]")
        track_ax.set_ylim(1e-12, 1e-5)
        track_ax.legend(loc="upper right", fontsize=8)
        rates = ",  ".join(f"{view.rate_name} = {state[view.rate]:+.1e}" for view in views)
        track_ax.set_title(f"t = {t:.3f} s,  {rates} rad/s", fontsize=8)
        fig.tight_layout()
        fig.canvas.draw()
        return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()

    @staticmethod
    def _draw_sail(ax, view: AxisView, state: np.ndarray, beam_input: np.ndarray) -> None:
        """The sail, struts and payload around the CoM, lateral motion exaggerated to be seen; the
        panel widens to keep the whole drawing inside it."""
        a, lc, strut, r = view.aperture_m, view.com_distance_m, view.strut_length_m, view.curvature_radius_m
        exaggerate_x = 0.25 * a / max(2e-2, abs(state[view.x]), view.offset_scale)
        exaggerate_theta = 0.2 / max(2e-3, abs(state[view.tilt]), view.tilt_scale)
        x0, theta = state[view.x] * exaggerate_x, view.tilt_sign * state[view.tilt] * exaggerate_theta
        axis = np.array([np.sin(theta), np.cos(theta)])  # (lateral, along the beam)
        side = np.array([np.cos(theta), -np.sin(theta)])
        com = np.array([x0, 0.0])
        vertex = com + lc * axis
        s = np.linspace(-a, a, 41)
        sag = 0.0 if np.isinf(r) else r - np.sqrt(r**2 - s**2)
        sail = vertex + np.outer(s, side) - np.outer(sag, axis)
        payload = com - (strut - lc) * axis
        beam_x = beam_input[view.offset] * exaggerate_x
        ax.axvspan(beam_x - a, beam_x + a, color="gold", alpha=0.25, lw=0)
        ax.axvline(0.0, color="grey", lw=0.8, ls=":")
        ax.plot(sail[:, 0], sail[:, 1], color="tab:blue", lw=2)
        for end in (sail[0], sail[-1]):
            ax.plot([end[0], payload[0]], [end[1], payload[1]], color="0.4", lw=0.8)
        ax.plot(*payload, "s", color="k", ms=5)
        ax.plot(*com, "o", color="tab:orange", ms=4)
        reach = max(2 * a, 1.1 * float(np.abs(np.concatenate([sail[:, 0], [payload[0], beam_x - a, beam_x + a]])).max()))
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-(strut - lc) - 2, lc + 2)
        ax.set_aspect("equal")
        # Short lines: the panels are narrow, and a title wider than its panel ran into the next one's.
        ax.set_title(f"{view.plane} (exaggerated)\n{view.x_name} = {state[view.x] * 1e3:+.2f} mm\n"
                     f"{view.tilt_name} = {state[view.tilt] * 1e3:+.3f} mrad", fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])


class AxisView:
    """What a sail panel draws of a task's sail: its geometry and, by name, the state's and inputs' entries
    on one lateral axis (the planar model's, or the 3D model's ``"x"`` or ``"y"``)."""

    def __init__(self, spec: EpisodeSpec, axis: str = "x") -> None:
        plant, config = spec.plant, spec.config
        sail = getattr(config, "sail", config)  # a RigidTaskConfig's RigidSailConfig, or the SailConfig
        self.aperture_m, self.com_distance_m = sail.aperture_radius_m, sail.com_distance_m
        self.strut_length_m = sail.strut_length_m
        self.curvature_radius_m = np.inf if getattr(sail, "shape", "dish") == "flat" else sail.curvature_radius_m
        names, inputs = plant.state_names, plant.input_names
        self.velocities = [names.index(n) for n in ("vx", "vy") if n in names]
        if "theta_y" in names:
            # x moves with θy; y with −θx (the 3D model's ``dvy/dt = −(F/m) θx``): drawn in the y–z plane
            # with that sign, so that the sail leans the way it pushes itself.
            about = "y" if axis == "x" else "x"
            self.plane, self.x_name, self.tilt_name, self.rate_name = f"{axis}–z plane", axis, f"θ{about}", f"ω{about}"
            self.x, self.tilt, self.rate = names.index(axis), names.index(f"theta_{about}"), names.index(f"omega_{about}")
            self.tilt_sign = 1.0 if axis == "x" else -1.0
            self.offset, tilt_input = inputs.index(f"beam_offset_{axis}"), inputs.index(f"beam_tilt_{axis}")
        else:
            self.plane, self.x_name, self.tilt_name, self.rate_name = "sail on its beam", "X", "θ", "ω"
            self.x, self.tilt, self.rate = names.index("x"), names.index("theta"), names.index("omega")
            self.tilt_sign = 1.0
            self.offset, tilt_input = inputs.index("beam_offset"), inputs.index("beam_tilt")
        self.offset_scale, self.tilt_scale = spec.action_scale[self.offset], spec.action_scale[tilt_input]


def axis_views(spec: EpisodeSpec) -> list[AxisView]:
    """The sail panels of a frame: the planar model's one axis, or the 3D model's x and y."""
    return [AxisView(spec, axis) for axis in (("x", "y") if "theta_y" in spec.plant.state_names else ("x",))]
