"""Rendering and videos: backend selection, frames, MP4/GIF files (GL runs in a subprocess)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from magsoft_env import gl as backend


def test_backend_error_names_the_debian_packages(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.delitem(sys.modules, "mujoco", raising=False)
    monkeypatch.setattr(backend, "probe_gl_backend", lambda b: f"cannot open {b}")
    with pytest.raises(backend.RenderBackendError) as err:
        backend.select_gl_backend()
    msg = str(err.value)
    assert "libegl1" in msg and "libgl1-mesa-dri" in msg and "libosmesa6" in msg
    assert "MUJOCO_GL=egl: cannot open egl" in msg and "MUJOCO_GL=osmesa" in msg


def test_user_choice_of_backend_is_respected(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(backend, "_library_loads", lambda name: True)
    monkeypatch.setattr(backend, "probe_gl_backend", lambda b: pytest.fail("must not probe"))
    assert backend.select_gl_backend() == "osmesa"


OSMESA_MISSING = not backend._library_loads("OSMesa")


@pytest.mark.skipif(not OSMESA_MISSING, reason="OSMesa is installed here: nothing missing to report")
@pytest.mark.parametrize("argv", [["gait", "--preset", "paper-5c", "--seconds", "0.1"],
                                  ["video", "--preset", "paper-5c", "--seconds", "0.1", "--out", "never.mp4"]])
def test_missing_osmesa_is_one_line_naming_the_package(argv, tmp_path):
    env = {**os.environ, "MUJOCO_GL": "osmesa"}
    env.pop("PYOPENGL_PLATFORM", None)
    r = subprocess.run([sys.executable, "-m", "magsoft_env.cli", *argv], capture_output=True, text=True,
                       env=env, cwd=tmp_path, timeout=300)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr + r.stdout
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith(f"magsoft {argv[0]}: error: MUJOCO_GL=osmesa but the OSMesa library")
    assert "apt-get install libosmesa6" in lines[0]
    assert not (tmp_path / "never.mp4").exists()


@pytest.mark.parametrize("value, library, packages", [("egl", "EGL", "libegl1 and libgl1-mesa-dri"),
                                                      ("OSMesa", "OSMesa", "libosmesa6")])
def test_missing_library_message_and_error(monkeypatch, value, library, packages):
    monkeypatch.setenv("MUJOCO_GL", value)
    monkeypatch.setattr(backend, "_library_loads", lambda name: False)
    msg = backend.missing_gl_library()
    assert f"the {library} library (lib{library}.so) is not installed" in msg
    assert f"apt-get install {packages}" in msg and "\n" not in msg
    with pytest.raises(backend.GLLibraryMissing, match="is not installed"):
        backend.select_gl_backend()
    with pytest.raises(backend.RenderBackendError):  # callers that catch the general error still catch it
        backend.check_gl_library()


@pytest.mark.parametrize("value", [None, "", "glfw", "egl"])
def test_no_message_when_nothing_is_missing(monkeypatch, value):
    if value is None:
        monkeypatch.delenv("MUJOCO_GL", raising=False)
    else:
        monkeypatch.setenv("MUJOCO_GL", value)
    monkeypatch.setattr(backend, "_library_loads", lambda name: True)
    assert backend.missing_gl_library() == ""


def test_video_path_must_be_mp4_or_gif(tmp_path):
    from magsoft_env.render.video import write_video

    with pytest.raises(ValueError, match="must end in one of"):
        write_video([np.zeros((8, 8, 3), np.uint8)], tmp_path / "a.avi")
    with pytest.raises(ValueError, match="at least one frame"):
        write_video([], tmp_path / "a.gif")


_SCRIPT = r"""
import json, sys
import numpy as np
import imageio.v2 as iio
from magsoft_env.render.video import render_gait
from magsoft_env.cases.gaits import gait_preset
import gymnasium as gym
import magsoft_env
out = sys.argv[1]
frames, s = render_gait(gait_preset("paper-5c"), 0.4, out + "/g.mp4", fps=10, width=160, height=96,
                        timestep=5e-4, segments=8)
mp4 = iio.mimread(out + "/g.mp4")
frames2, _ = render_gait(gait_preset("paper-5a"), 0.2, out + "/g.gif", fps=10, width=96, height=64,
                         timestep=5e-4, segments=6)
gif = iio.mimread(out + "/g.gif")
diffs = [float(np.abs(frames[i + 1].astype(int) - frames[i]).mean()) for i in range(len(frames) - 1)]
env = gym.make("MagSoftShape-v0", render_mode="rgb_array", segments=6, width=64, height=48)
env.reset(seed=0)
env.step(np.array([0.2, 0.5], np.float32))
img = env.render()
env2 = gym.make("MagSoftCrawl-v1", render_mode="rgb_array", segments=6, width=64, height=48)
env2.reset(seed=0)
img2 = env2.render()
print(json.dumps({"n": len(frames), "mp4": len(mp4), "shape": list(mp4[0].shape), "gif": len(gif),
                  "min_diff": min(diffs), "env_shape": list(img.shape), "env_dtype": str(img.dtype),
                  "env2_shape": list(img2.shape), "message": s["message"]}))
"""


def _run_gl(tmp_path):
    env = {**os.environ}
    env.setdefault("MUJOCO_GL", "egl")
    r = subprocess.run([sys.executable, "-c", _SCRIPT, str(tmp_path)], capture_output=True, text=True, env=env,
                       timeout=300)
    if r.returncode != 0 and ("GL" in r.stderr or "EGL" in r.stderr) and "Error" in r.stderr.splitlines()[-1]:
        pytest.skip(f"no headless OpenGL here: {r.stderr.strip().splitlines()[-1]}")
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_videos_have_the_expected_frames_and_they_change(tmp_path):
    res = _run_gl(tmp_path)
    assert res["message"] == "ok"
    assert res["n"] == 5 and res["mp4"] == 5  # 0.4 s at 10 fps, plus the first frame
    assert res["shape"] == [96, 160, 3]
    assert res["gif"] == 3
    assert res["min_diff"] > 0.0  # every frame differs from the one before
    assert res["env_shape"] == [48, 64, 3] and res["env_dtype"] == "uint8"
    assert res["env2_shape"] == [48, 64, 3]


def test_video_cli_writes_a_gif(tmp_path):
    env = {**os.environ}
    env.setdefault("MUJOCO_GL", "egl")
    out = tmp_path / "crawl.gif"
    r = subprocess.run(
        [sys.executable, "-m", "magsoft_env.cli", "video", "--preset", "paper-5a", "--seconds", "0.2", "--fps", "10",
         "--width", "64", "--height", "48", "--timestep-ms", "0.5", "--out", str(out)],
        capture_output=True, text=True, env=env, timeout=300,
    )
    if r.returncode == 1 and "headless OpenGL" in r.stdout:
        pytest.skip("no headless OpenGL here")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["frames"] == 3 and out.exists()


def test_video_cli_rejects_bad_input_before_any_work(capsys):
    from magsoft_env.cli import main

    assert main(["video", "--preset", "paper-5a", "--out", "x.avi"]) == 2
    assert "--out must end in one of" in capsys.readouterr().err
    assert main(["video", "--env", "MagSoftCrawl-v1", "--seconds", "0", "--out", "x.gif"]) == 2
    assert "--seconds must be > 0" in capsys.readouterr().err


def test_video_cli_robot_file_with_panel(tmp_path):
    """``--robot FILE`` renders like ``--preset``; ``--panel`` widens the frames by the panel."""
    from magsoft_env.cases.robots import robots_dir

    env = {**os.environ}
    env.setdefault("MUJOCO_GL", "egl")
    out = tmp_path / "robot.gif"
    r = subprocess.run(
        [sys.executable, "-m", "magsoft_env.cli", "video", "--robot", str(robots_dir() / "paper-5c.yml"), "--seconds",
         "0.2", "--fps", "10", "--width", "64", "--height", "48", "--timestep-ms", "0.5", "--panel", "--out", str(out)],
        capture_output=True, text=True, env=env, timeout=300,
    )
    if r.returncode == 1 and "headless OpenGL" in r.stdout:
        pytest.skip("no headless OpenGL here")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["frames"] == 3 and summary["width"] == 64 + 2 * round(0.45 * 48) and summary["height"] == 48
    import imageio.v2 as iio

    assert iio.mimread(out)[0].shape[:2] == (48, 108)


def test_video_cli_defaults_to_960x540():
    from magsoft_env.cli import build_parser

    args = build_parser().parse_args(["video", "--preset", "paper-5c", "--out", "x.mp4"])
    assert (args.width, args.height, args.panel, args.robot) == (960, 540, False, None)


@pytest.mark.parametrize(("argv", "fragment"), [
    (["--preset", "paper-5a", "--robot", "paper-5c"], "--preset and --robot both name the robot"),
    ([], "one of the arguments --preset --env is required"),
    (["--robot", "missing.yml"], "does not exist"),
    (["--robot", "paper-5x"], "Did you mean 'paper-5c'"),
    (["--robot", "paper-5c", "--panel", "--seconds", "1e4", "--timestep-ms", "10"], "in memory"),
])
def test_video_cli_robot_and_panel_errors_before_any_work(tmp_path, capsys, argv, fragment):
    from magsoft_env.cli import main

    out = tmp_path / "never" / "x.gif"
    assert main(["video", *argv, "--out", str(out)]) == 2
    assert fragment in capsys.readouterr().err
    assert not out.parent.exists()
