"""The student's distillation settings, as a frozen dataclass."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StudentConfig:
    """DAgger (Ross et al. 2011) from a privileged teacher to a student that sees a depth
    image and the peg's own pose (the "peg" reading), never the hole's pose. Its camera is the
    env's (sim.cameras: the wrist's depth, 64 x 64, in benchmarks/vision.py)."""

    collect_steps: int = 250
    """Vector steps of play per DAgger iteration (x envs frames, each labelled by the
    teacher)."""
    grad_steps: int = 400
    """Gradient steps on the aggregated frames after each iteration's play."""
    batch_size: int = 256
    """Frames per gradient step."""
    learning_rate: float = 3e-4
    """Adam's step size."""
    buffer_size: int = 200_000
    """Frames kept (the oldest go first): 0.8 GB of 64 x 64 depth in float16."""
    beta_decay: float = 0.5
    """Share of episodes the teacher drives: 1 in the first iteration, then this power of the
    iteration's number (DAgger's beta_i = p^i); the student drives the rest."""
    feature_dim: int = 256
    """The image encoder's output features."""
    hidden: tuple[int, ...] = (256, 256)
    """The head's hidden layers (image features and the peg's pose in, the action out)."""
    nearest_seat: bool = True
    """Show the teacher the nearest of the seat's frames that look the same (a peg that fits
    its hole turned by half a turn: rl/student/symmetry.py), so that its labels are a function
    of what the camera sees; False: the seat's own frame."""

    def validate(self) -> StudentConfig:
        """Self, or ValueError naming each value out of its range."""
        checks = {
            "collect_steps >= 1": self.collect_steps >= 1,
            "grad_steps >= 1": self.grad_steps >= 1,
            "batch_size >= 1": self.batch_size >= 1,
            "learning_rate > 0": self.learning_rate > 0,
            "buffer_size >= batch_size": self.buffer_size >= self.batch_size,
            "0 <= beta_decay < 1": 0.0 <= self.beta_decay < 1.0,
            "feature_dim >= 1": self.feature_dim >= 1,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"StudentConfig: these must hold: {bad}")
        return self
