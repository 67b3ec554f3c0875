"""What a training run checks around its folder (section 4.5's runs, made safe to stop and resume).

* :func:`claim` runs before a run builds its trainer: it locks the folder
  (:mod:`jaxdc.training.lock`, one run per folder), clears the partial step
  a killed save left, and with ``resume`` checks at once that the checkpoint
  to continue from exists and fits the run's settings and that the metrics
  CSVs are sound, so that a refusal does not wait for the build.
* :func:`resume` restores the checkpoint; a damaged one (unreadable, or
  holding a NaN or an infinity) is refused naming the run folder and the step,
  with the intact steps and how to continue from one (``resume_step``).
* :func:`state_problem` says why a training state must not be evaluated or
  saved (a NaN or an infinity in its parameters or optimiser state).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import jax

from jaxdc import checkpoint
from jaxdc import metadata as metadata_format
from jaxdc.core.tree_check import non_finite, slash_path
from jaxdc.training.fields import SettingError
from jaxdc.training.lock import FolderLock, lock_folder
from jaxdc.training.metrics import read_rows

if TYPE_CHECKING:
    from jaxdc.training.loop import RunControl


def claim(control: RunControl, metadata: dict, csv_paths: Sequence[str], primary: bool = True) -> FolderLock | None:
    """Lock ``control.out`` and check what a resume needs (see the module); the lock, held by the caller.

    With several processes (:mod:`jaxdc.training.distributed`) only process 0 (``primary``) locks and tidies the
    folder, which they share; the others only check it and hold no lock (``None``)."""
    if not primary:
        if control.resume:
            _check_resume(control, metadata, csv_paths)
        return None
    lock = lock_folder(control.out)
    try:
        checkpoint.remove_partial(control.ckpt_dir)
        if control.resume:
            _check_resume(control, metadata, csv_paths)
    except BaseException:
        lock.release()
        raise
    return lock


def _check_resume(control: RunControl, metadata: dict, csv_paths: Sequence[str]) -> None:
    existing = checkpoint.steps(control.ckpt_dir)
    if not existing:
        raise SettingError(f"{{0}}: no checkpoint found in {SettingError.text(control.ckpt_dir)}", "resume")
    step = control.resume_step
    if step is not None and step not in existing:
        raise SettingError(f"{{0}} {step}: {SettingError.text(control.ckpt_dir)} holds no checkpoint {step} (its "
                           f"steps: {existing})", "resume_step")
    try:
        checkpoint.check_metadata(control.ckpt_dir, step, metadata, upgrade=metadata_format.upgrade)
    except checkpoint.Damaged:
        pass  # :func:`resume` names the intact steps
    for path in csv_paths:
        read_rows(path, 0)  # refuses a damaged file


def resume(control: RunControl, target: Any, metadata: dict, primary: bool = True) -> Any:
    """The state of checkpoint ``control.resume_step`` (default: the latest) of the run, restored into the
    structure of ``target``; the checkpoints after it are deleted (the run writes them anew). A damaged step is a
    :class:`SettingError` naming the folder, the step and the intact steps."""
    ckpt = control.ckpt_dir
    step = control.resume_step if control.resume_step is not None else checkpoint.steps(ckpt)[-1]
    try:
        state, _ = checkpoint.restore(ckpt, target, metadata, step=step, upgrade=metadata_format.upgrade)
    except checkpoint.Damaged as e:
        intact = checkpoint.intact_steps(ckpt, target, metadata, upgrade=metadata_format.upgrade, exclude=(step,))
        where = f"{SettingError.text(e)}. The run in {SettingError.text(control.out)} cannot continue from step {step}"
        if not intact:
            raise SettingError(f"{where}, and no other checkpoint of it is intact; start it again in another {{0}}",
                               "out") from None
        raise SettingError(f"{where}. Intact checkpoints: steps {intact}; continue from one with {{0}} {{1}} STEP "
                           f"(e.g. {{1}} {intact[-1]}; the checkpoints after it are deleted and their metrics rows "
                           "dropped)", "resume", "resume_step") from None
    later = checkpoint.delete_after(ckpt, step) if primary else []  # process 0 tidies the shared folder
    if later:
        print(f"resume: continuing {control.out} from checkpoint {step}; deleted the later checkpoints {later}",
              file=sys.stderr)
    return state


def state_problem(state: Any) -> str | None:
    """Why ``state`` must not be evaluated or checkpointed (``"the training state holds N NaN or infinite values
    in /params/..."``), or ``None`` if every float array of it is finite."""
    bad = non_finite(jax.device_get(state), key=slash_path)
    if not bad:
        return None
    arrays = ", ".join(k for k, _ in bad[:3]) + (f" and {len(bad) - 3} more arrays" if len(bad) > 3 else "")
    return f"the training state holds {sum(n for _, n in bad)} NaN or infinite values in {arrays}"
