"""A small training loop that knows nothing about the model or the data.

The caller gives three things: the model, ``sample_batch(step, generator) -> batch`` and
``loss_fn(model, batch) -> loss`` (or ``(loss, {"name": float, ...})``). Everything else —
optimiser, learning-rate schedule, gradient clipping, device, progress bar, timing — is set by
a :class:`TrainerConfig`::

    config = TrainerConfig(steps=2000, batch_size=64, lr=1e-3, lr_schedule="cosine")
    result = train(model, lambda step, g: dataset.sample(config.batch_size, g),
                   lambda model, batch: F.mse_loss(model(batch["x"]), batch["y"]), config)
    result.plot()

Runs are repeatable: batches are drawn with a ``torch.Generator`` seeded from
``config.seed``, and the global torch random state (used by dropout) is seeded inside the
loop and restored afterwards, so two CPU runs from the same initial model are bit-identical.
"""
from __future__ import annotations

import dataclasses
import math
import time
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any, Callable, Optional, Sequence

import torch
from .._validate import check_choice, check_numbers, check_positive_ints
from .device import choose_device
from .progress import progress_bar
from .seeding import check_seed

__all__ = ["TrainerConfig", "TrainResult", "TrainedModel", "train", "trainer_config", "learning_rate_factor",
           "move_to_device"]

LR_SCHEDULES = ("constant", "cosine", "onecycle")
OPTIMIZERS = ("adamw", "adam")


@dataclass(frozen=True)
class TrainerConfig:
    """How to optimise (not what): the knobs of :func:`train`.

    Attributes:
        steps: optimiser steps.
        batch_size: batch size; read by the caller's ``sample_batch`` (the trainer draws no data).
        lr: peak learning rate.
        weight_decay: decoupled weight decay for AdamW, L2 penalty for Adam.
        grad_clip: clip the global gradient norm to this value; ``None`` for no clipping.
        lr_schedule: ``"constant"`` (after warm-up), ``"cosine"`` (warm-up, then cosine decay to
            0) or ``"onecycle"`` (the learning-rate part of the one-cycle policy, which NIFTY's
            interaction field uses; its shape is PyTorch's ``OneCycleLR`` defaults, not stated by
            NIFTY: from lr/25 up to lr over 30 % of the steps, then cosine down to lr/25e4).
        warmup_steps: linear warm-up steps (for ``"onecycle"``: the rising phase, 30 % of
            ``steps`` when 0).
        log_every: read the losses back from the device (one sync) and update the progress bar
            every this many steps; a NaN or infinite loss is reported at the next read-back.
        device: ``"auto"``, ``"cpu"``, ``"cuda"``, ``"cuda:N"`` or ``"mps"``.
        progress: ``True`` always shows a progress bar; ``False`` shows one where progress shows by default (a
            Jupyter kernel, ``HOI_PROGRESS=1``, ``infra.show_progress()``: ``infra.progress``).
        seed: seeds the batch generator and the random state used inside the model (dropout).
        optimizer: ``"adamw"`` or ``"adam"``.
    """

    steps: int = 1000
    batch_size: int = 64
    lr: float = 1e-3
    weight_decay: float = 0.0
    grad_clip: Optional[float] = None
    lr_schedule: str = "constant"
    warmup_steps: int = 0
    log_every: int = 50
    device: str = "auto"
    progress: bool = False
    seed: int = 0
    optimizer: str = "adamw"

    def __post_init__(self):
        check_choice(self.lr_schedule, LR_SCHEDULES, "lr_schedule")
        check_choice(self.optimizer, OPTIMIZERS, "optimizer")
        check_positive_ints(self, ("steps", "batch_size", "log_every"))
        if not isinstance(self.warmup_steps, int) or not 0 <= self.warmup_steps <= self.steps:
            raise ValueError(f"warmup_steps: expected an int in [0, steps={self.steps}], "
                             f"got {self.warmup_steps!r}")
        check_seed(self.seed, "seed")
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("weight_decay",), at_least=0)
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)


@dataclass
class TrainResult:
    """What a training run leaves behind.

    Attributes:
        losses: the loss at every step.
        seconds: wall-clock time of the loop.
        extra: every value ``loss_fn`` reported besides the loss, one list per name.
    """

    losses: list = field(default_factory=list)
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)

    @property
    def final_loss(self) -> float:
        """Mean loss over the last 5 % of steps (at least one step)."""
        tail = self.losses[-max(1, len(self.losses) // 20):]
        return sum(tail) / len(tail)

    def plot(self, ax=None, label: str = "loss"):
        """Draw the loss curve (log y axis; a moving average on top when the run is long)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 3))
        steps = range(len(self.losses))
        line, = ax.plot(steps, self.losses, lw=0.8, alpha=0.4 if len(self.losses) > 50 else 1.0,
                        label=label)
        if len(self.losses) > 50:
            window = max(5, len(self.losses) // 50)
            kernel = torch.ones(1, 1, window) / window
            smooth = torch.nn.functional.conv1d(torch.tensor(self.losses).view(1, 1, -1), kernel)
            ax.plot(range(window - 1, len(self.losses)), smooth.view(-1).tolist(),
                    color=line.get_color(), lw=1.5, label=f"{label} (moving average)")
        ax.set_yscale("log")
        ax.set_xlabel("step")
        ax.set_ylabel("loss")
        ax.legend(frameon=False)
        return ax


@dataclass
class TrainedModel:
    """A trained model as a ``trained_*`` function returns it (built, or loaded from the cache).

    Attributes:
        model: the model in eval mode, on the CPU.
        losses: ``(steps,)`` float32, the training loss at every step.
        seconds: wall-clock seconds the training took when it ran (not the load).
        details: what else the builder records, documented by each ``trained_*`` function (e.g.
            ``n_sequences``, the number of training examples).
    """

    model: torch.nn.Module
    losses: torch.Tensor
    seconds: float
    details: dict = field(default_factory=dict)

    def plot(self, ax=None, label: str = "loss"):
        """The loss curve, as :meth:`TrainResult.plot` draws it."""
        return TrainResult(losses=[float(v) for v in self.losses]).plot(ax=ax, label=label)


_TRAINER_FIELDS = ("steps", "batch_size", "lr", "weight_decay", "grad_clip", "lr_schedule", "warmup_steps",
                   "seed", "optimizer")


def trainer_config(config, device="cpu", progress: bool = False, **overrides) -> TrainerConfig:
    """The :class:`TrainerConfig` of a component's configuration: every field the two share is copied.

    A component config (e.g. ``nifty.motion_model.MotionModelConfig``) holds its optimisation
    settings beside its model settings; this reads ``steps``, ``batch_size``, ``lr``,
    ``weight_decay``, ``grad_clip``, ``lr_schedule``, ``warmup_steps``, ``seed`` and ``optimizer``
    where it has them (the others keep :class:`TrainerConfig`'s defaults). The warm-up is cut to
    ``steps`` so a short run (a test overriding ``steps``) keeps a valid schedule.

    Args:
        config: a dataclass instance with at least ``steps``.
        device, progress: as :class:`TrainerConfig`.
        overrides: :class:`TrainerConfig` fields to set explicitly.
    """
    if not dataclasses.is_dataclass(config) or not hasattr(config, "steps"):
        raise TypeError(f"config: expected a configuration dataclass with a 'steps' field, "
                        f"got {type(config).__name__}")
    values = {name: getattr(config, name) for name in _TRAINER_FIELDS if hasattr(config, name)}
    values.update(overrides)
    steps = values["steps"]
    if isinstance(steps, int) and isinstance(values.get("warmup_steps"), int):
        values["warmup_steps"] = min(values["warmup_steps"], steps)
    return TrainerConfig(device=str(device), progress=progress, **values)


def learning_rate_factor(schedule: str, step: int, steps: int, warmup_steps: int = 0) -> float:
    """The multiplier on the peak learning rate at ``step`` (0-based) of ``steps``."""
    check_choice(schedule, LR_SCHEDULES, "lr_schedule")
    if schedule == "onecycle":
        # torch.optim.lr_scheduler.OneCycleLR's two cosine phases (anneal_strategy="cos"), step for step.
        rise_end = (warmup_steps or 0.3 * steps) - 1.0
        start, peak, end = 1.0 / 25.0, 1.0, 1.0 / 25e4
        if step <= rise_end:
            t, a, b = (step / rise_end if rise_end > 0 else 1.0), start, peak
        else:
            t, a, b = min(1.0, (step - rise_end) / max(1e-12, steps - 1 - rise_end)), peak, end
        return b + (a - b) * 0.5 * (1.0 + math.cos(math.pi * t))
    if step < warmup_steps:
        return (step + 1) / warmup_steps
    if schedule == "constant":
        return 1.0
    t = min(1.0, (step - warmup_steps) / max(1, steps - warmup_steps))
    return 0.5 * (1.0 + math.cos(math.pi * t))


def move_to_device(batch, device: torch.device):
    """Move every tensor in a (nested) dict / list / tuple to ``device``; others stay as they are."""
    if isinstance(batch, torch.Tensor):
        return batch.to(device)
    if isinstance(batch, dict):
        return type(batch)((key, move_to_device(value, device)) for key, value in batch.items())
    if isinstance(batch, tuple) and hasattr(batch, "_fields"):
        return type(batch)(*(move_to_device(value, device) for value in batch))
    if isinstance(batch, (list, tuple)):
        return type(batch)(move_to_device(value, device) for value in batch)
    return batch


def _make_optimizer(parameters, config: TrainerConfig, foreach: bool = True) -> torch.optim.Optimizer:
    # foreach: one update over all parameters instead of a loop over them (torch's default on CUDA only); the
    # same arithmetic, so the same bits as the loop (tests/test_infra.py), in a third less time on the CPU.
    if config.optimizer == "adamw":
        return torch.optim.AdamW(parameters, lr=config.lr, weight_decay=config.weight_decay, foreach=foreach)
    return torch.optim.Adam(parameters, lr=config.lr, weight_decay=config.weight_decay, foreach=foreach)


def train(model: torch.nn.Module, sample_batch: Callable[[int, torch.Generator], Any],
          loss_fn: Callable[[torch.nn.Module, Any], Any], config: TrainerConfig, *,
          callbacks: Sequence[Callable] = ()) -> TrainResult:
    """Optimise ``model`` for ``config.steps`` steps; the model is trained in place.

    Args:
        model: any ``torch.nn.Module``; moved to ``config.device``.
        sample_batch: ``sample_batch(step, generator) -> batch`` draws one batch (a tensor, or a
            dict / list / tuple of them) using the CPU ``torch.Generator`` it is given.
        loss_fn: ``loss_fn(model, batch)`` returns a scalar loss tensor, or ``(loss, logs)``
            where ``logs`` maps names to floats (collected in ``TrainResult.extra``).
        config: the optimisation settings.
        callbacks: each is called as ``callback(step, model, loss, logs)`` after every step;
            returning ``True`` stops training.

    Returns:
        a :class:`TrainResult` with the per-step losses, wall-clock seconds and extra logs.

    Raises:
        ValueError: when the loss is not a scalar. FloatingPointError: when it is NaN or inf.
    """
    if not isinstance(config, TrainerConfig):
        raise TypeError(f"config: expected a TrainerConfig, got {type(config).__name__}")
    device = choose_device(config.device)
    was_training = model.training
    model.to(device).train()
    parameters = [p for p in model.parameters() if p.requires_grad]
    if not parameters:
        raise ValueError("model: expected at least one parameter that requires grad")
    optimizer = _make_optimizer(parameters, config)
    scheduler = torch.optim.lr_scheduler.LambdaLR(
        optimizer, lambda step: learning_rate_factor(config.lr_schedule, step, config.steps,
                                                     config.warmup_steps))
    generator = torch.Generator().manual_seed(config.seed)
    result = TrainResult()
    extra = defaultdict(list)
    cuda_devices = [device] if device.type == "cuda" else []
    start = time.perf_counter()
    # Seed the global state the model's own randomness reads (dropout), then put it back.
    with torch.random.fork_rng(devices=cuda_devices):
        torch.manual_seed(config.seed)
        # a bar where progress shows (``progress.progress_enabled``), always when asked for; drawn in the
        # notebook's process when this runs in a ``warm_cache`` worker
        bar = progress_bar(range(config.steps), config.steps, type(model).__name__, enabled=config.progress or None)
        pending = []  # (step, loss tensor, logs) since the last read-back: one device sync per interval

        def flush():
            # Read the losses of the pending steps back at once (a GPU syncs once per interval).
            values = torch.stack([loss for _, loss, _ in pending]).tolist() if pending else []
            stop = False
            for (step_, _, logs_), value in zip(pending, values):
                if not math.isfinite(value):
                    raise FloatingPointError(f"loss became {value} at step {step_}")
                result.losses.append(value)
                logs_ = {name: float(v) for name, v in logs_.items()}
                for name, v in logs_.items():
                    extra[name].append(v)
                stop = any([callback(step_, model, value, logs_) is True for callback in callbacks]) or stop
            if values:
                bar.set_postfix(loss=f"{values[-1]:.4g}")
            pending.clear()
            return stop

        for step in bar:
            batch = move_to_device(sample_batch(step, generator), device)
            output = loss_fn(model, batch)
            loss, logs = output if isinstance(output, tuple) else (output, {})
            if not isinstance(loss, torch.Tensor) or loss.ndim != 0:
                shape = tuple(loss.shape) if isinstance(loss, torch.Tensor) else type(loss).__name__
                raise ValueError(f"loss_fn: expected a scalar tensor, got {shape}")
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            if config.grad_clip is not None:
                torch.nn.utils.clip_grad_norm_(parameters, config.grad_clip)
            optimizer.step()
            scheduler.step()
            pending.append((step, loss.detach(), logs))
            if (callbacks or (step + 1) % config.log_every == 0 or step == config.steps - 1) and flush():
                break
        flush()
        bar.close()
    result.seconds = time.perf_counter() - start
    result.extra = dict(extra)
    model.train(was_training)
    return result
