"""ROS map_server PGM + YAML maps, read with Nav2's semantics; every bad file named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hal.occupancy_map import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    MapFileError,
    parse_pgm,
    read_map_yaml,
)

YAML = """image: {image}
resolution: 0.050000
origin: [-10.000000, -2.500000, 0.000000]
negate: {negate}
occupied_thresh: 0.65
free_thresh: 0.196
{extra}"""


def _pgm(pixels: list[list[int]], maxval: int = 255, magic: bytes = b"P5") -> bytes:
    h, w = len(pixels), len(pixels[0])
    head = magic + b"\n# CREATOR: map_saver.cpp 0.050 m/pix\n" + f"{w} {h}\n{maxval}\n".encode()
    if magic == b"P2":
        return head + " ".join(str(v) for row in pixels for v in row).encode() + b"\n"
    return head + bytes(v for row in pixels for v in row)


def _write(tmp_path: Path, pixels: list[list[int]], *, negate: int = 0, extra: str = "",
           pgm: bytes | None = None, image: str = "map.pgm") -> Path:
    (tmp_path / "map.pgm").write_bytes(pgm if pgm is not None else _pgm(pixels))
    path = tmp_path / "map.yaml"
    path.write_text(YAML.format(image=image, negate=negate, extra=extra))
    return path


class TestReading:
    def test_map_saver_shades_become_free_occupied_unknown(self, tmp_path: Path) -> None:
        """254 is free, 0 occupied, 205 unknown (map_saver's three shades)."""
        m = read_map_yaml(_write(tmp_path, [[254, 0, 205]]))
        assert m.cells.tolist() == [[FREE, OCCUPIED, UNKNOWN]]

    def test_the_top_image_row_is_the_highest_y(self, tmp_path: Path) -> None:
        """Image row 0 is the top of the map: grid row 0 is the image's last row."""
        m = read_map_yaml(_write(tmp_path, [[0, 0], [254, 254], [254, 205]]))
        assert m.cells[0].tolist() == [FREE, UNKNOWN]
        assert m.cells[2].tolist() == [OCCUPIED, OCCUPIED]

    def test_origin_with_negative_coordinates_and_resolution_are_kept(
            self, tmp_path: Path) -> None:
        """The origin is the lower-left corner, negative values included."""
        m = read_map_yaml(_write(tmp_path, [[254]]))
        assert (m.origin_x_m, m.origin_y_m, m.resolution_m) == (-10.0, -2.5, 0.05)

    def test_negate_swaps_black_and_white(self, tmp_path: Path) -> None:
        """negate: 1 makes white occupied and black free (thresholds read the same way)."""
        # occ = p / 255: 254 -> 0.996, 0 -> 0, 205 -> 0.80 (occupied too), 100 -> 0.39.
        m = read_map_yaml(_write(tmp_path, [[254, 0, 205, 100]], negate=1))
        assert m.cells.tolist() == [[OCCUPIED, FREE, OCCUPIED, UNKNOWN]]

    def test_thresholds_are_strict_as_in_nav2(self, tmp_path: Path) -> None:
        """occ exactly at a threshold is unknown (Nav2 compares with < and >)."""
        # occ = 1 - p/255; p = 89.25 would be 0.65 exactly; 90 -> 0.647 (unknown),
        # 89 -> 0.651 (occupied); free below 0.196: p > 205.02.
        m = read_map_yaml(_write(tmp_path, [[89, 90, 205, 206]]))
        assert m.cells.tolist() == [[OCCUPIED, UNKNOWN, UNKNOWN, FREE]]

    def test_scale_mode_spreads_between_the_thresholds(self, tmp_path: Path) -> None:
        """mode: scale gives 1..99 between the thresholds."""
        m = read_map_yaml(_write(tmp_path, [[254, 150, 0]], extra="mode: scale\n"))
        assert m.cells[0, 0] == FREE and m.cells[0, 2] == OCCUPIED
        assert 0 < m.cells[0, 1] < 100

    def test_raw_mode_takes_the_values(self, tmp_path: Path) -> None:
        """mode: raw: the pixel value is the cell when 0..100, else unknown."""
        m = read_map_yaml(_write(tmp_path, [[0, 42, 100, 200]], extra="mode: raw\n"))
        assert m.cells.tolist() == [[0, 42, 100, UNKNOWN]]

    def test_plain_and_sixteen_bit_pgms_read_alike(self) -> None:
        """P2 and 16-bit P5 give the same pixels as 8-bit P5."""
        p5, _ = parse_pgm(_pgm([[1, 2], [3, 4]]), "a")
        p2, _ = parse_pgm(_pgm([[1, 2], [3, 4]], magic=b"P2"), "b")
        wide = b"P5 2 1 65535\n" + np.array([1000, 65535], dtype=">u2").tobytes()
        p16, maxval = parse_pgm(wide, "c")
        assert p5.tolist() == p2.tolist() == [[1, 2], [3, 4]]
        assert p16.tolist() == [[1000, 65535]] and maxval == 65535

    def test_quoted_image_comments_and_absolute_paths(self, tmp_path: Path) -> None:
        """Comments, quotes and an absolute image path are understood."""
        (tmp_path / "sub").mkdir()
        (tmp_path / "sub" / "m.pgm").write_bytes(_pgm([[0]]))
        path = tmp_path / "x.yaml"
        path.write_text(f'# saved\nimage: "{tmp_path}/sub/m.pgm"  # abs\nresolution: 0.1\n'
                        "origin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.25\n")
        assert read_map_yaml(path).cells.tolist() == [[OCCUPIED]]


BAD_YAML = [
    ("resolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "image: required key is missing"),
    ("image: m.pgm\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
     "resolution: required key is missing"),
    ("image: m.pgm\nresolution: fast\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\n", ":2: resolution: expected a number"),
    ("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\n", "resolution: must be > 0"),
    ("image: m.pgm\nresolution: 0.05\norigin: [0, 0]\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\n", ":3: origin: expected 3 elements"),
    ("image: m.pgm\nresolution: 0.05\norigin: 0\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\n", "origin: expected [x, y, yaw]"),
    ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 1.2]\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\n", "yaw 1.2 is not supported"),
    ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.2\n"
     "free_thresh: 0.65\n", "must satisfy 0 <= free_thresh < occupied_thresh <= 1"),
    ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\nnegate: maybe\n", ":6: negate: expected 0 or 1"),
    ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\nmode: fuzzy\n", ":6: mode: expected one of trinary, scale, raw"),
    ("image: m.pgm\nresolution: 0.05\norigin:\n  - 0\n", ":4: expected 'key: value'"),
    ("image: ''\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
     "free_thresh: 0.2\n", "the image tag is empty"),
]


class TestErrors:
    @pytest.mark.parametrize(("text", "message"), BAD_YAML)
    def test_a_bad_yaml_is_named_with_what_is_wrong(self, tmp_path: Path, text: str,
                                                    message: str) -> None:
        """Each broken YAML gets 'PATH[:LINE]: what is wrong'."""
        (tmp_path / "m.pgm").write_bytes(_pgm([[0]]))
        path = tmp_path / "bad.yaml"
        path.write_text(text)
        with pytest.raises(MapFileError) as info:
            read_map_yaml(path)
        assert str(info.value).startswith(str(path))
        assert message in str(info.value)

    @pytest.mark.parametrize(("pgm", "message"), [
        (b"P6 1 1 255\n\x00\x00\x00", "not a PGM image"),
        (b"P5 2 2 255\n\x00\x00", "image data is truncated (2 of 4 pixels)"),
        (b"P5 2", "PGM header is truncated"),
        (b"P5 a b 255\n", "expected width, height and maxval"),
        (b"P5 0 2 255\n", "PGM size 0x2 is out of range"),
        (b"P5 1 1 0\n\x00", "maxval must be 1-65535"),
        (b"P2 1 1 9\n10\n", "a pixel exceeds maxval 9"),
        (b"P2 2 1 9\n1 x\n", "plain PGM pixels are not all integers"),
    ])
    def test_a_bad_image_is_named_with_what_is_wrong(self, tmp_path: Path, pgm: bytes,
                                                     message: str) -> None:
        """Each broken PGM gets 'IMAGE PATH: what is wrong'."""
        path = _write(tmp_path, [[0]], pgm=pgm)
        with pytest.raises(MapFileError, match=r"map\.pgm: ") as info:
            read_map_yaml(path)
        assert message in str(info.value)

    def test_missing_files_are_named(self, tmp_path: Path) -> None:
        """No YAML, or a YAML whose image is missing, says which file."""
        with pytest.raises(MapFileError, match=r"nope\.yaml: cannot read"):
            read_map_yaml(tmp_path / "nope.yaml")
        path = _write(tmp_path, [[0]], image="gone.pgm")
        with pytest.raises(MapFileError, match=r"map.yaml: image: .*gone.pgm: cannot read"):
            read_map_yaml(path)


class TestCheckConfig:
    def test_a_map_that_does_not_parse_is_a_config_problem(self, tmp_path: Path) -> None:
        """check-config (and the daemon's start) refuse a bad map: map.file: PATH: what."""
        from robotd.config.errors import ConfigError
        from robotd.config.loader import load_config_text

        path = _write(tmp_path, [[0]], pgm=b"P5 2 2 255\n\x00")
        config = tmp_path / "robotd.toml"
        with pytest.raises(ConfigError) as info:
            load_config_text('[map]\nfile = "map.yaml"\n', str(config))
        assert f"{config}:2: map.file: {tmp_path}/map.pgm: image data is truncated" in str(
            info.value)
        assert path.exists()
        _write(tmp_path, [[0]])
        assert load_config_text('[map]\nfile = "map.yaml"\n', str(config))["map"]["file"]
