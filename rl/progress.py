"""The training run's console (stderr) and its progress bar over env steps."""

from __future__ import annotations

from rich.console import Console

console = Console(stderr=True, highlight=False)


class ProgressBar:
    """A rich progress bar over env steps (or elapsed time only when there is no total)."""

    def __init__(self, enabled: bool, total: int | None, done: int) -> None:
        self.p = None
        if not enabled:
            return
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.p = Progress(
            TextColumn("[bold]train"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=console,
        )
        self.p.start()
        self.task = self.p.add_task("train", total=total, completed=done, info="")

    def update(self, advance: int, row: dict[str, float]) -> None:
        if self.p is None:
            return
        info = (
            f"{row['steps_per_s']:,.0f} steps/s  success {row['success_rate']:.1%}  "
            f"return {row['return_mean']:.3f}"
        )
        self.p.update(self.task, advance=advance, info=info)

    def close(self) -> None:
        if self.p is not None:
            self.p.stop()
