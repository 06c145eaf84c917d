"""robotd.viz.messages: the camera image's half-size copy."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from robotd.viz.messages import every_other_pixel, jpeg_image

_SHAPES = st.tuples(st.integers(1, 41), st.integers(1, 41), st.sampled_from([(), (3,)]))


class TestEveryOtherPixel:
    @given(_SHAPES.flatmap(lambda s: arrays(np.uint8, (s[0], s[1], *s[2]))))
    def test_is_the_strided_copy_to_the_byte(self, image: np.ndarray) -> None:
        """Any size, even or odd, grey or BGR: the bytes of image[::2, ::2], contiguous."""
        half = every_other_pixel(image)
        assert half.flags.c_contiguous
        assert half.dtype == np.uint8
        assert np.array_equal(half, image[::2, ::2])

    def test_the_camera_size_takes_the_resize(self) -> None:
        """320 x 240 BGR (the line camera): the same pixels as slicing."""
        image = np.random.default_rng(7).integers(0, 256, (240, 320, 3), dtype=np.uint8)
        assert np.array_equal(every_other_pixel(image), image[::2, ::2])

    def test_wide_frames_of_even_and_odd_sizes_are_encoded(self) -> None:
        """jpeg_image halves a frame wider than 200 px, whichever way the copy is made."""
        for shape in ((240, 320, 3), (241, 321, 3), (240, 320)):
            image = np.full(shape, 128, np.uint8)
            assert jpeg_image(0, image, [(160, 120)], "camera") is not None

    def test_the_marks_are_not_drawn_on_the_caller_s_image(self) -> None:
        """A small image is sent whole: its marks go on a copy, the caller's stays as it was."""
        for shape in ((120, 160, 3), (240, 320, 3)):
            image = np.full(shape, 128, np.uint8)
            assert jpeg_image(0, image, [(50, 40)], "camera") is not None
            assert (image == 128).all()
