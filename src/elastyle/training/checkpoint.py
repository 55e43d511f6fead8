"""Training checkpoints: the network's and optimiser's state, the step, the time spent and the settings,
written atomically as training goes (and on Ctrl-C, which ends training after the step under way)."""

from __future__ import annotations

import io
import json
import logging
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

from elastyle.errors import ElastyleError, OutputError
from elastyle.io.files import write_bytes_atomic
from elastyle.model.config import ModelConfig
from elastyle.training.config import TrainConfig

log = logging.getLogger(__name__)


def read_checkpoint(path: str) -> dict[str, Any]:
    """A training checkpoint's state, or a one-line `ElastyleError` for a file that is not one."""
    import torch

    try:
        state = torch.load(path, weights_only=True)
    except Exception:  # torch raises many kinds for a file that is not its own
        raise ElastyleError(
            f"{path}: not a training checkpoint (MODEL.npz.ckpt; a model file .npz cannot be resumed)"
        ) from None
    if not isinstance(state, dict) or not {"network", "optimizer", "step", "elapsed_s"} <= set(state):
        raise ElastyleError(f"{path}: not a training checkpoint (MODEL.npz.ckpt)")
    return state


def checkpoint_config(path: str) -> TrainConfig | None:
    """The settings a checkpoint's training ran with (its budget too), or None for a checkpoint written
    before they were recorded; a one-line `ElastyleError` for a file that is not a checkpoint."""
    return recorded_config(read_checkpoint(path))


def recorded_config(state: dict[str, Any]) -> TrainConfig | None:
    """The settings recorded in a checkpoint's state (`checkpoint_config`)."""
    recorded = state.get("train_config")
    if not isinstance(recorded, str):
        return None
    values = json.loads(recorded)
    known = {f.name for f in fields(TrainConfig)}
    model = ModelConfig(**values.pop("model"))
    values["speed_range"] = tuple(values.get("speed_range", TrainConfig.speed_range))
    return TrainConfig(model=model, **{name: value for name, value in values.items() if name in known})


class StopOnInterrupt:
    """Ctrl-C (SIGINT) or a kill (SIGTERM) asks training to stop after the step under way (`asked`), so its
    checkpoint holds whole steps; a second one interrupts at once. In the main thread only (elsewhere:
    nothing changes); `release` restores the handlers it replaced."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.asked = False
        self._previous: dict[int, Any] = {}
        if threading.current_thread() is threading.main_thread():
            self._previous = {number: signal.signal(number, self._ask) for number in self.SIGNALS}

    def _ask(self, signum: int, frame: Any) -> None:
        self.asked = True
        for number in self.SIGNALS:  # a second one stops at once
            signal.signal(number, _interrupt_now)

    def release(self) -> None:
        for number, previous in self._previous.items():
            signal.signal(number, previous)
        self._previous = {}


def _interrupt_now(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


@contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Ctrl-C or a kill during the block takes effect as it ends (a KeyboardInterrupt then): for torch's
    import, which, cut short, left the command killed by the signal after it said it was interrupted, or
    aborting. In the main thread only (elsewhere: nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    asked: list[int] = []
    previous = {
        number: signal.signal(number, lambda signum, frame: asked.append(signum))
        for number in StopOnInterrupt.SIGNALS
    }
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
    if asked:
        raise KeyboardInterrupt


def save_checkpoint(
    path: Path,
    network: Any,
    optimizer: Any,
    step: int,
    elapsed_s: float,
    config: TrainConfig,
    clip_names: list[str],
    required: bool = True,
) -> bool:
    """The training's state, and the settings it runs with (`checkpoint_config`), written atomically
    (`io.files.write_bytes_atomic`: no temporary file left where it cannot be, a full disk). Where it cannot
    be: an `OutputError` naming the file if `required` (what an interrupted training leaves), else a
    warning, the training going on without it. Whether it was written."""
    import torch

    buffer = io.BytesIO()
    torch.save(
        {
            "network": network.state_dict(),
            "optimizer": optimizer.state_dict(),
            "step": step,
            "elapsed_s": elapsed_s,
            "train_config": json.dumps(asdict(config)),
            "clip_names": clip_names,
        },
        buffer,
    )
    try:
        write_bytes_atomic(path, buffer.getvalue(), force=True)
    except OutputError as error:
        if required:
            raise
        log.warning("warning: the checkpoint is not written (%s); training goes on without it", error)
        return False
    return True
