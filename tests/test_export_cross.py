"""``mpc.export_c`` cross-compiled: the exported Mecanum library, with daqp built from its
released source package (``MPC_DAQP_SOURCE``), built for 32-bit ARM (armhf, the roboRIO's
class) and aarch64 with Debian's cross compilers, statically linked and run under
``qemu-user`` on the recorded ticks of ``tests/test_export.py``: the same statuses, and
twists and wheel speeds to 1e-9, as the Python tick and as the native (x86-64) build of the
same source. Both ARM targets compute in IEEE double (armhf's VFP included), so 1e-9 holds
unchanged. Skips only where cmake, a cross compiler, qemu or daqp's sdist is missing."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest
from test_export import _windows
from tick_loop import DT, HORIZON, Broken, record

import mpc
import mpc.tick.build
from mpc import Command, Controller, Status
from mpc.robots import preset
from mpc.tick.export import DAQP_RELEASE
from trajectories import FigureEight

# The sdist, downloaded once and kept (gitignored) between runs.
CACHE = Path(__file__).resolve().parents[1] / "tmp" / "cache" / "daqp"
# target: (its C compiler, its qemu-user, CMAKE_SYSTEM_PROCESSOR)
TARGETS = {"armhf": ("arm-linux-gnueabihf-gcc", "qemu-arm", "arm"),
           "aarch64": ("aarch64-linux-gnu-gcc", "qemu-aarch64", "aarch64")}
TRAJECTORIES = {"beyond": FigureEight(1.0, 6.0, heading="tangent"),
                "reference fails": Broken(1.0, 16.0, heading="tangent")}
STATUSES = (Status.SOLVED, Status.PREVIOUS_PLAN, Status.FEEDFORWARD, Status.STOPPING)

pytestmark = pytest.mark.skipif(shutil.which("cmake") is None or shutil.which("gcc") is None,
                                reason="needs cmake and gcc")


@pytest.fixture(scope="module")
def daqp_source() -> Path:
    """daqp's released source (``DAQP_RELEASE``), from ``pip download`` (cached)."""
    folder = CACHE / f"daqp-{DAQP_RELEASE}"
    if not (folder / "csrc" / "src" / "api.c").is_file():
        CACHE.mkdir(parents=True, exist_ok=True)
        archive = CACHE / f"daqp-{DAQP_RELEASE}.tar.gz"
        if not archive.is_file():
            done = subprocess.run(
                [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
                 "--no-binary", ":all:", f"daqp=={DAQP_RELEASE}", "-d", str(CACHE)],
                capture_output=True, text=True, timeout=300)
            if done.returncode != 0 or not archive.is_file():
                pytest.skip(f"no daqp {DAQP_RELEASE} sdist: pip download failed (no network?):"
                            f" {done.stderr.strip()[-300:]}")
        with tarfile.open(archive) as tar:
            if hasattr(tarfile, "data_filter"):  # Python 3.11.4 and later
                tar.extractall(CACHE, filter="data")
            else:  # Debian's 3.11.2: the same refusal of paths outside CACHE, by hand
                for member in tar.getmembers():
                    if (member.name.startswith("/") or ".." in Path(member.name).parts
                            or not (member.isfile() or member.isdir())):
                        pytest.fail(f"unexpected member in the daqp sdist: {member.name}")
                tar.extractall(CACHE)
    return folder


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The exported Mecanum controller (horizon 8, as in ``tests/test_export.py``)."""
    controller = Controller(preset("mecanum"), FigureEight(1.0, 16.0), horizon=HORIZON,
                            dt=DT, compiled="virtual-machine")
    return mpc.export_c(controller, tmp_path_factory.mktemp("export-cross") / "src")


def _build(source: Path, build: Path, daqp: Path, *options: str) -> Path:
    """The example program, configured and built with CMake (daqp from ``daqp``)."""
    for command in (["cmake", "-S", str(source), "-B", str(build),
                     f"-DMPC_DAQP_SOURCE={daqp}", *options],
                    ["cmake", "--build", str(build), "-j", "2"]):
        done = subprocess.run(command, capture_output=True, text=True)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return build / "mpc_tick_example"


@pytest.fixture(scope="module")
def ticks() -> dict[str, tuple[str, list[Command]]]:
    """Each trajectory's recorded ticks as the example program's stdin, and the Python
    tick's commands on them."""
    recorded = {}
    for name, trajectory in TRAJECTORIES.items():
        poses, expected = record("mecanum", trajectory)
        lines = [" ".join(repr(float(value)) for value in
                          np.concatenate([pose, window.ravel(), velocities.ravel()]))
                 for pose, (window, velocities)
                 in zip(poses, _windows(trajectory, len(poses)), strict=True)]
        recorded[name] = "\n".join(lines) + "\n", expected
    return recorded


def _run(command: list[str], stdin: str) -> np.ndarray:
    """The program's rows: status, twist (3), wheel speeds."""
    done = subprocess.run(command, input=stdin, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    return np.array([line.split() for line in done.stdout.splitlines()], dtype=float)


def _assert_same(rows: np.ndarray, expected: list[Command]) -> None:
    """Statuses equal; twists and wheel speeds to 1e-9."""
    assert rows.shape == (len(expected), 4 + 4)
    assert np.all(np.isfinite(rows))
    for tick, (row, command) in enumerate(zip(rows, expected, strict=True)):
        assert STATUSES[int(row[0])] is command.status, tick
        np.testing.assert_allclose(row[1:4], command.twist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(row[4:], command.wheel_speeds, rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def native(source: Path, daqp_source: Path, ticks: dict[str, tuple[str, list[Command]]]
           ) -> dict[str, np.ndarray]:
    """The native build of daqp's source: its rows per trajectory (checked against the
    Python tick, so the source build is the wheel's daqp)."""
    program = _build(source, source.parent / "native", daqp_source)
    rows = {}
    for name, (stdin, expected) in ticks.items():
        rows[name] = _run([str(program)], stdin)
        _assert_same(rows[name], expected)
    return rows


def test_the_daqp_release_is_the_casadi_wheels(daqp_source: Path) -> None:
    """tick.c uses daqp's internals: DAQP_RELEASE's headers are the casadi wheel's (all but
    ``codegen.h``, casadi's addition, which tick.c does not use)."""
    wheel = mpc.tick.build.casadi_folder() / "include" / "daqp"
    ours = daqp_source / "csrc" / "include"
    headers = {path.name for path in wheel.glob("*.h")} - {"codegen.h"}
    assert headers and headers <= {path.name for path in ours.glob("*.h")}
    for name in sorted(headers):
        assert (ours / name).read_bytes() == (wheel / name).read_bytes(), (
            f"casadi's daqp/{name} is not daqp {DAQP_RELEASE}'s: update DAQP_RELEASE")


def test_a_cross_build_without_daqp_source_stops_with_advice(source: Path) -> None:
    """Cross-compiling with the wheel's x86-64 libdaqpstat.a is refused at configure."""
    done = subprocess.run(["cmake", "-S", str(source), "-B", str(source.parent / "refused"),
                           "-DCMAKE_SYSTEM_NAME=Linux", "-DCMAKE_C_COMPILER=gcc"],
                          capture_output=True, text=True)
    assert done.returncode != 0 and "MPC_DAQP_SOURCE" in done.stderr


@pytest.mark.parametrize("target", sorted(TARGETS))
def test_the_cross_built_library_gives_the_same_commands_under_qemu(
        target: str, request: pytest.FixtureRequest) -> None:
    compiler, qemu, processor = TARGETS[target]
    missing = [tool for tool in (compiler, qemu) if shutil.which(tool) is None]
    if missing:  # before the fixtures: nothing built for a skipped target
        pytest.skip(f"{target}: {' and '.join(missing)} not installed (Debian: apt-get install"
                    " gcc-arm-linux-gnueabihf gcc-aarch64-linux-gnu qemu-user)")
    source: Path = request.getfixturevalue("source")
    daqp_source: Path = request.getfixturevalue("daqp_source")
    ticks: dict[str, tuple[str, list[Command]]] = request.getfixturevalue("ticks")
    native: dict[str, np.ndarray] = request.getfixturevalue("native")
    program = _build(source, source.parent / target, daqp_source,
                     "-DCMAKE_SYSTEM_NAME=Linux", f"-DCMAKE_SYSTEM_PROCESSOR={processor}",
                     f"-DCMAKE_C_COMPILER={compiler}", "-DCMAKE_EXE_LINKER_FLAGS=-static")
    kind = subprocess.run(["file", str(program)], capture_output=True, text=True).stdout
    assert not kind or ("ARM" if target == "armhf" else "aarch64") in kind, kind
    for name, (stdin, expected) in ticks.items():
        rows = _run([qemu, str(program)], stdin)
        _assert_same(rows, expected)
        assert np.array_equal(rows[:, 0], native[name][:, 0]), name
        np.testing.assert_allclose(rows[:, 1:], native[name][:, 1:], rtol=0, atol=1e-9,
                                   err_msg=name)
