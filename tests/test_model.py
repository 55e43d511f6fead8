"""The autoencoder: numpy inference against torch, the model file, and a short real training."""

from __future__ import annotations

import os
import shlex
from pathlib import Path

import numpy as np
import pytest

from elastyle import ModelError, SkeletonMismatchError, read_bvh
from elastyle.model.file import FORMAT_VERSION, load_model, save_model

torch = pytest.importorskip("torch")


@pytest.mark.parametrize("tied", [True, False])
def test_numpy_forward_matches_torch(tied: bool) -> None:
    from elastyle.model.config import ModelConfig
    from elastyle.training.network import TorchAutoencoder

    torch.manual_seed(0)
    config = ModelConfig(hidden_channels=64, latent_channels=16, kernel_frames=15, tied=tied)
    network = TorchAutoencoder(config, 21)
    x = torch.randn(1, 21, 90)
    with torch.no_grad():
        latents_torch = network.encode(x)[0].T.numpy()
        output_torch = network(x)[0].T.numpy()
    from elastyle.model.autoencoder import Autoencoder

    numpy_model = Autoencoder(config, network.numpy_weights())
    features = x[0].T.numpy()
    np.testing.assert_allclose(numpy_model.encode(features), latents_torch, atol=1e-5)
    np.testing.assert_allclose(numpy_model.decode(latents_torch), output_torch, atol=1e-5)
    # decoded at chosen frames only (the out-of-depth check's every third), the ends' zero padding included
    frames = np.array([0, 1, 7, 45, 88, 89])
    np.testing.assert_allclose(numpy_model.decode(latents_torch, frames), output_torch[frames], atol=1e-5)


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory, data_path: Path):  # type: ignore[no-untyped-def]
    """A short real training on a small subset of dataset walks (a few hundred steps)."""
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    out = tmp_path_factory.mktemp("model") / "walks.npz"
    data = (
        f"{data_path}/bandai-namco-2/data/dataset-2_walk_*_00[1-6].bvh"
        if str(data_path).endswith(".zip")
        else str(data_path)
    )
    model = train([data], str(out), TrainConfig(steps=300, learning_rate=1e-3, seed=0), progress=False)
    return out, model


@pytest.mark.slow
def test_short_training_lowers_loss_and_round_trips(trained) -> None:  # type: ignore[no-untyped-def]
    path, model = trained
    assert model.metadata["steps"] == 300
    # an untrained autoencoder's loss on normalised features is about 1 (their variance)
    assert model.metadata["held_out_loss"] < 0.5
    assert "reconstruction_warn_cm" in model.metadata  # calibrated on the takes held out (005)
    assert abs(model.metadata["ground"] - 4.25) < 0.1  # their toes stand 4.25 cm above the floor
    assert model.metadata["final_train_loss"] < 0.5
    loaded = load_model(path)
    assert loaded.skeleton.names == model.skeleton.names
    np.testing.assert_array_equal(loaded.autoencoder.weights.conv1, model.autoencoder.weights.conv1)
    np.testing.assert_array_equal(loaded.feature_std, model.feature_std)
    assert loaded.fps == model.fps


@pytest.mark.slow
def test_training_resumes_from_checkpoint(trained, tmp_path: Path, data_path: Path) -> None:  # type: ignore[no-untyped-def]
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    path, model = trained
    checkpoint = Path(str(path) + ".ckpt")
    assert checkpoint.exists()
    data = (
        f"{data_path}/bandai-namco-2/data/dataset-2_walk_*_00[1-6].bvh"
        if str(data_path).endswith(".zip")
        else str(data_path)
    )
    resumed = train(
        [data],
        str(tmp_path / "more.npz"),
        TrainConfig(steps=300, learning_rate=1e-3, seed=1),  # another seed: a fresh start would differ
        resume=str(checkpoint),
        progress=False,
    )
    # resumed at the checkpoint's step 300 with a budget of 300: no step taken, the checkpoint's weights
    assert resumed.metadata["steps"] == 300
    # a checkpoint given where a model belongs is named as one (it read as 'no format_version')
    with pytest.raises(
        ModelError, match="a training checkpoint, not a model: `elastyle train CLIPS -o MODEL.npz --resume"
    ):
        load_model(checkpoint)
    np.testing.assert_array_equal(resumed.autoencoder.weights.conv1, model.autoencoder.weights.conv1)
    # the command line resumes with the settings the checkpoint records, where no flag says otherwise (a
    # model trained with --recipe shipped was refused when resumed without it)
    from dataclasses import replace

    from elastyle.cli import build_parser
    from elastyle.cli.train import train_config
    from elastyle.training.checkpoint import checkpoint_config

    recorded = checkpoint_config(str(checkpoint))
    assert recorded == TrainConfig(steps=300, learning_rate=1e-3, seed=0)
    flags = ["train", data, "-o", "m.npz", "--steps", "600", "--resume", str(checkpoint)]
    assert train_config(build_parser().parse_args(flags), recorded) == replace(recorded, steps=600)
    given = train_config(build_parser().parse_args([*flags, "--lr", "5e-4", "--no-mirror"]), recorded)
    assert given == replace(recorded, steps=600, learning_rate=5e-4, mirror_augment=False)


def test_shipped_model_loads_without_torch_and_pickle() -> None:
    import subprocess
    import sys

    code = (
        "import sys; sys.modules['torch'] = None\n"
        "from elastyle.model.file import load_model\n"
        "m = load_model(); print(m.skeleton.num_joints, m.fps)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split()[0] == "22"


def test_bad_model_files_give_model_errors(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="no such model file"):
        load_model(tmp_path / "missing.npz")
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"\x00\x01not a model at all")
    with pytest.raises(ModelError, match="not an elastyle model"):
        load_model(garbage)
    shipped = load_model()
    good = tmp_path / "good.npz"
    save_model(good, shipped)
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(ModelError, match="not an elastyle model"):
        load_model(truncated)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, weights=np.zeros(3))
    with pytest.raises(ModelError, match="no format_version"):
        load_model(foreign)
    with np.load(good, allow_pickle=False) as archive:
        arrays = {k: archive[k] for k in archive.files}
    arrays["format_version"] = np.array(FORMAT_VERSION + 1)
    newer = tmp_path / "newer.npz"
    np.savez(newer, **arrays)
    with pytest.raises(ModelError, match="format version"):
        load_model(newer)


def test_model_with_other_skeleton_lists_the_joints(three_channel_bvh: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    with pytest.raises(SkeletonMismatchError, match="only in the model: joint_Root, Hips"):
        load_model().check_clip(motion, "tiny_xyz.bvh")


def test_clips_shorter_than_a_training_window_are_said_and_not_counted(
    tmp_path: Path, three_channel_bvh: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A clip shorter than the training window gives none: two 3 s walks and a 1 s loop trained with 2 s
    windows left the loop out in silence, and the model said it was trained on 3 clips. Now a note says so
    and what window would include it, and the model counts 2; with that window, 3."""
    import logging

    from elastyle import write_bvh
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    motion, layout = read_bvh(three_channel_bvh)
    for take, frames in enumerate((90, 90, 30)):
        rotations = np.zeros((frames, motion.skeleton.num_joints, 3))
        rotations[:, 2, 0] = 0.5 * np.sin(np.arange(frames) / (6.0 + take))
        translations = np.repeat(motion.translations[:1], frames, axis=0)
        write_bvh(
            tmp_path / f"loop_{take + 1}.bvh",
            type(motion)(motion.skeleton, rotations, translations, 30.0),
            layout,
        )
    counts = {}
    for window_s in (2.0, 1.0):
        caplog.clear()
        with caplog.at_level(logging.INFO, logger="elastyle"):
            model = train(
                [str(tmp_path / "*.bvh")], str(tmp_path / f"m{window_s:g}.npz"),
                TrainConfig(steps=2, window_s=window_s, mirror_augment=False), progress=False,
            )  # fmt: skip
        counts[window_s] = model.metadata["training_clips"]
        said = [r.getMessage() for r in caplog.records if "shorter than the" in r.getMessage()]
        if window_s == 2.0:
            assert said and "1 of the 3 training clips" in said[0] and "--window-s 1.00" in said[0], said
        else:
            assert not said, said
    assert counts == {2.0: 2, 1.0: 3}


def test_a_checkpoint_the_disk_cannot_take_leaves_the_model_written(
    tmp_path: Path,
    three_channel_bvh: Path,
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The disk full as the checkpoint was written: training ended in "internal error", with a temporary file
    left and no model. Now it warns and goes on, and the model is written."""
    import logging

    from elastyle import OutputError, write_bvh
    from elastyle.training import checkpoint
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    motion, layout = read_bvh(three_channel_bvh)
    rotations = np.zeros((60, motion.skeleton.num_joints, 3))
    rotations[:, 2, 0] = 0.5 * np.sin(np.arange(60) / 6.0)
    translations = np.repeat(motion.translations[:1], 60, axis=0)
    clips = tmp_path / "clips"
    clips.mkdir()
    write_bvh(clips / "loop_1.bvh", type(motion)(motion.skeleton, rotations, translations, 30.0), layout)

    def full(path: object, data: bytes, force: bool = False) -> None:
        raise OutputError(f"{path}: write failed: No space left on device")

    monkeypatch.setattr(checkpoint, "write_bytes_atomic", full)
    output = clips / "m.npz"
    with caplog.at_level(logging.INFO, logger="elastyle"):
        train([str(clips / "*.bvh")], str(output), TrainConfig(steps=2, window_s=1.0), progress=False)
    assert load_model(output).metadata["steps"] == 2
    assert sorted(p.name for p in clips.iterdir()) == ["loop_1.bvh", "m.npz"]
    said = " ".join(r.getMessage() for r in caplog.records)
    assert "the checkpoint is not written" in said and "no checkpoint to resume it from" in said


def test_training_works_on_another_skeleton(tmp_path: Path, three_channel_bvh: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """A 3-channel skeleton of another naming scheme: train a few steps, then transfer with the model."""
    from elastyle import write_bvh
    from elastyle.pipeline import transfer
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    motion, layout = read_bvh(three_channel_bvh)
    swing = np.sin(np.arange(90) / 6.0)[:, None]  # (T, 1) a leg swing at about 0.8 Hz
    rotations = np.zeros((90, motion.skeleton.num_joints, 3))
    rotations[:, 2, 0] = 0.5 * swing[:, 0]
    rotations[:, 4, 0] = -0.5 * swing[:, 0]
    translations = np.repeat(motion.translations[:1], 90, axis=0)
    translations[:, 0, 2] = np.arange(90) * 0.5  # walking forward along +Z
    for take in range(3):
        clip = type(motion)(motion.skeleton, rotations * (1 + 0.2 * take), translations, 30.0)
        write_bvh(tmp_path / f"walk_{take}.bvh", clip, layout)
    model = train(
        [str(tmp_path / "*.bvh")],
        str(tmp_path / "own.npz"),
        TrainConfig(steps=3, window_s=2.0, perturb_augment=0.5),
        progress=False,
    )
    assert model.skeleton.names == motion.skeleton.names
    # where the model comes from, without the user's folders; `info` says it
    assert model.metadata["data"] == ["*.bvh"] and model.metadata["excluded"] == []
    assert model.metadata["elastyle_version"] and model.metadata["trained_utc"][:2] == "20"
    from elastyle.cli import _print_model_info

    _print_model_info(str(tmp_path / "own.npz"))
    assert "  data:     *.bvh; 20" in capsys.readouterr().out
    loaded = load_model(tmp_path / "own.npz")
    style, _ = read_bvh(tmp_path / "walk_2.bvh")
    content, _ = read_bvh(tmp_path / "walk_0.bvh")
    out = transfer(content, style, model=loaded).motion
    assert out.skeleton.names == content.skeleton.names and np.all(np.isfinite(out.rotations))
    # strength 0 is the content itself on this skeleton too, although a 3-step model reproduces nothing
    same = transfer(content, style, model=loaded, strength=0.0).motion
    np.testing.assert_allclose(same.positions(), content.positions(), atol=5e-4)
    plain = transfer(content, style, model=loaded, strength=0.0, decode="plain").motion
    assert np.abs(plain.positions() - content.positions()).max() > 0.1


@pytest.mark.slow
def test_the_position_loss_weighs_alike_in_any_length_unit(tmp_path: Path, dataset_clips) -> None:  # type: ignore[no-untyped-def]
    """The position loss counted file units: a rig in metres trained without it (its positions 100 times
    smaller, the term 10,000 times weaker), and its model drew its held-out takes about 60 % worse."""
    from elastyle import write_bvh
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    walks = [c for c in dataset_clips if "_walk_normal_00" in c.name][:4]
    losses = []
    for unit, factor in (("cm", 1.0), ("m", 0.01)):
        folder = tmp_path / unit
        folder.mkdir()
        for clip in walks:
            write_bvh(folder / Path(clip.member or clip.name).name, clip.read()[0].scaled(factor))
        model = train(
            [str(folder)], str(tmp_path / f"{unit}.npz"),
            TrainConfig(steps=3, window_s=2.0, position_loss=1.0, mirror_augment=False), progress=False,
        )  # fmt: skip
        losses.append(model.metadata["final_train_loss"])
    assert losses[1] == pytest.approx(losses[0], rel=1e-3)


@pytest.mark.slow
def test_a_stray_clip_of_another_rig_is_the_one_named(
    tmp_path: Path, dataset_clips, three_channel_bvh: Path
) -> None:  # type: ignore[no-untyped-def]
    """The first clip in name order was the reference: one stray clip sorting first had every one of the
    user's clips named as the one that differs."""
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    for clip in [c for c in dataset_clips if "_walk_normal_00" in c.name][:3]:
        (tmp_path / Path(clip.member or clip.name).name).write_bytes(clip.data())
    stray = tmp_path / "a_stray.bvh"  # sorts first
    stray.write_text(three_channel_bvh.read_text())
    with pytest.raises(
        SkeletonMismatchError, match=r"a_stray\.bvh: skeleton differs from .*dataset-2_walk.*--exclude"
    ):
        train([str(tmp_path)], str(tmp_path / "m.npz"), TrainConfig(steps=1), progress=False)


def test_a_clip_the_shipped_model_reads_given_with_another_rigs_model_is_told_so(
    tmp_path: Path, three_channel_bvh: Path, content
) -> None:  # type: ignore[no-untyped-def]
    """The error told the user to train a model for the dataset's skeleton, which the shipped one reads."""
    from elastyle import write_bvh
    from elastyle.pipeline import transfer
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    motion, layout = read_bvh(three_channel_bvh)
    rotations = np.zeros((60, motion.skeleton.num_joints, 3))
    rotations[:, 2, 0] = 0.5 * np.sin(np.arange(60) / 6.0)  # a leg swinging
    clip = type(motion)(motion.skeleton, rotations, np.repeat(motion.translations[:1], 60, axis=0), 30.0)
    for take in range(3):
        write_bvh(tmp_path / f"own_{take}.bvh", clip, layout)
    own = train(
        [str(tmp_path / "*.bvh")],
        str(tmp_path / "own.npz"),
        TrainConfig(steps=2, window_s=1.0),
        progress=False,
    )
    with pytest.raises(
        SkeletonMismatchError, match="the shipped model reads this skeleton: leave out --model"
    ):
        transfer(content, content, model=own)
    with pytest.raises(
        SkeletonMismatchError, match="train a model on its clips"
    ):  # the shipped model's advice
        transfer(motion, motion)


def test_perturbation_moves_whole_joints_within_their_recorded_ranges() -> None:
    from elastyle.training.windows import perturb_windows

    rng = np.random.default_rng(0)
    windows = rng.uniform(-1, 1, size=(64, 9, 20)).astype(np.float32)  # (B, C, W): 3 joints x 3 channels
    groups = np.repeat(np.arange(3), 3)
    low, high = np.full(9, -1.2, np.float32), np.full(9, 1.2, np.float32)  # the recorded ranges
    assert np.array_equal(perturb_windows(windows, 0.0, 0.5, groups, low, high, rng), windows)
    perturbed = perturb_windows(windows, 0.5, 0.5, groups, low, high, rng)
    moved = np.any(perturbed != windows, axis=2).reshape(64, 3, 3)  # (B, joint, channel)
    assert np.all(moved.all(axis=2) == moved.any(axis=2))  # a joint's channels move together
    assert 10 < moved.any(axis=(1, 2)).sum() < 54  # about half the windows
    assert perturbed.min() >= -1.2 and perturbed.max() <= 1.2  # never past the recorded range


@pytest.mark.slow
def test_ctrl_c_ends_training_with_a_checkpoint_to_resume(tmp_path: Path, data_path: Path) -> None:
    """Ctrl-C during training: the step under way finishes, a checkpoint is written and named with the
    command that resumes it, and no model file (before: the steps since the last 500th were lost, unsaid)."""
    import signal
    import subprocess
    import sys
    import time

    data = (
        f"{data_path}/bandai-namco-2/data/dataset-2_walk_normal_00[1-4].bvh"
        if str(data_path).endswith(".zip")
        else str(data_path)
    )
    output = tmp_path / "m.npz"
    command = [sys.executable, "-m", "elastyle.cli", "train", data, "-o", str(output), "--steps", "100000",
               "--threads", "1", "--exclude", "*_004", "--force"]  # fmt: skip
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    checkpoint = Path(str(output) + ".ckpt")
    assert process.stderr is not None
    before = []
    for line in process.stderr:  # without a terminal, a line at each checkpoint: the steps are running
        before.append(line)
        if line.startswith("step "):
            break
    assert process.poll() is None, "".join(before)
    time.sleep(1)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert "interrupted at step" in stderr and f"--resume {checkpoint}" in stderr, stderr
    # the command to continue names the clips, as chosen and into the same file, and the budget (a resume
    # without a budget is refused; without the --exclude and --force given it took other clips, or refused)
    resume = f"--resume {checkpoint} --exclude '*_004' --force --steps 100000`"
    assert f"elastyle train {shlex.quote(data)} -o {output} {resume}" in stderr, stderr
    assert "warning: 3 training clip(s)" in "".join(before)  # so few clips are said to teach little
    assert checkpoint.exists() and not output.exists()
    assert "Traceback" not in stderr


@pytest.mark.slow
def test_ctrl_c_while_the_clips_load_ends_training_cleanly(tmp_path: Path, dataset_clips) -> None:  # type: ignore[no-untyped-def]
    """Ctrl-C reaches the whole process group: the processes reading the clips each printed a traceback, and
    the command could end with an internal error (BrokenProcessPool, exit 1) or torch's cache statistics."""
    import signal
    import subprocess
    import sys
    import time

    clips = [c for c in dataset_clips if "_walk_" in c.name][:24]  # more than 8: read by a process pool
    for clip in clips:
        (tmp_path / Path(clip.member or clip.name).name).write_bytes(clip.data())
    for delay in (
        0.8,
        1.2,
        1.6,
        2.0,
    ):  # after start-up, wherever it lands: reading, importing torch, training
        command = [sys.executable, "-m", "elastyle.cli", "train", str(tmp_path), "-o", str(tmp_path / "m.npz"),
                   "--minutes", "1", "--no-progress", "--force"]  # fmt: skip
        process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True, start_new_session=True)
        time.sleep(delay)
        os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C does
        _, stderr = process.communicate(timeout=60)
        # 130 from elastyle's handler; a Ctrl-C before the interpreter has set one up ends it by the signal
        assert process.returncode in (130, -signal.SIGINT), (delay, stderr)
        assert "Traceback" not in stderr and "internal error" not in stderr and "cache_hits" not in stderr, (
            stderr
        )


@pytest.mark.slow
def test_resuming_on_other_clips_says_so(trained, tmp_path: Path, data_path: Path, caplog) -> None:  # type: ignore[no-untyped-def]
    """Before, a checkpoint resumed on another set of clips went on silently, its normalisation read anew."""
    import logging

    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    path, _ = trained
    if not str(data_path).endswith(".zip"):
        pytest.skip("the clip globs below name clips inside the dataset zip")
    fewer = f"{data_path}/bandai-namco-2/data/dataset-2_walk_*_00[1-3].bvh"
    with caplog.at_level(logging.INFO, logger="elastyle"):
        train([fewer], str(tmp_path / "other.npz"), TrainConfig(steps=300, learning_rate=1e-3, seed=0),
              resume=str(path) + ".ckpt", progress=False)  # fmt: skip
    assert any("was trained on" in r.message and "these are" in r.message for r in caplog.records)
    assert any("wrote" in r.message and "after 300 steps" in r.message for r in caplog.records)


def test_a_resumed_cosine_schedule_goes_on_from_its_checkpoints_rate() -> None:
    """Resumed with the budget it had, a run decays its learning rate as an uninterrupted run does; with a
    larger budget the rate falls on from where the checkpoint left it to the floor at the new end (before,
    it rose again at the resume); after its budget was spent, at the floor."""
    from elastyle.training.config import TrainConfig
    from elastyle.training.rate import FLOOR, LearningRate, spent_fraction

    fresh = LearningRate(1e-3, cosine=True)
    same = LearningRate(1e-3, True, reached=0.4, resumed_at=0.4)
    for fraction in (0.4, 0.7, 1.0):
        assert same.at(fraction) == pytest.approx(fresh.at(fraction))
    # 400 of 1000 steps done, resumed with a budget of 2000: the rate at the resume is the checkpoint's,
    # then it falls without rising to the floor at the new end
    checkpoint, longer = TrainConfig(steps=1000), TrainConfig(steps=2000)
    larger = LearningRate(1e-3, True, spent_fraction(checkpoint, 400, 0.0), spent_fraction(longer, 400, 0.0))
    rates = [larger.at(spent_fraction(longer, step, 0.0)) for step in range(400, 2001, 100)]
    assert rates[0] == pytest.approx(fresh.at(0.4))
    assert all(later <= earlier for earlier, later in zip(rates, rates[1:]))
    assert rates[-1] == pytest.approx(FLOOR * 1e-3)
    spent = LearningRate(1e-3, True, reached=1.0, resumed_at=0.5)
    assert spent.at(0.5) == spent.at(0.9) == pytest.approx(FLOOR * 1e-3)
    assert LearningRate(1e-3, cosine=False).at(0.7) == 1e-3
    minutes = TrainConfig(minutes=10)
    assert spent_fraction(minutes, 0, 300.0) == pytest.approx(0.5)
