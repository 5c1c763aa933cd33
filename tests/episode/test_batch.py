"""cpgjax/episode/batch.py: the width of a batch on one device (the batch itself: test_rollout.py)."""

from types import SimpleNamespace

import pytest

from cpgjax.episode.batch import LANES, lanes


@pytest.mark.parametrize("n, springs, exact", [
    (1, 16, 16), (16, 16, 16), (17, 32, 32), (33, 48, 64), (48, 48, 64), (65, 80, 128), (100, 112, 128),
    (256, 256, 256), (257, 272, 512),
])
def test_a_batch_is_whole_simd_vectors_and_on_exact_joints_a_power_of_two_of_them(n, springs, exact):
    # exact joints give a robot the same bits only at power-of-two widths (cpgjax/episode/batch.py: lanes)
    assert lanes(SimpleNamespace(pipeline="springs"), n) == springs
    assert lanes(SimpleNamespace(pipeline="exact"), n) == exact
    assert exact % LANES == 0 and (exact // LANES) & (exact // LANES - 1) == 0


@pytest.mark.parametrize("per_dev, chunk, springs, exact", [
    (600, 208, 208, 128),     # make thesis's sweep: 5 chunks of 128 (640 robots), not 3 of 256 (768)
    (10, 256, 16, 16), (128, 256, 128, 128), (300, 256, 256, 128), (520, 256, 256, 128), (40, 256, 48, 64),
    (600, 64, 64, 64),
    (256, 256, 256, 128), (1000, 256, 256, 128),   # ties go to 128: faster per robot than 256 (batch.py)
])
def test_a_device_runs_its_robots_in_chunks_that_pad_them_little(per_dev, chunk, springs, exact):
    from cpgjax.episode.batch import chunk_width

    assert chunk_width(SimpleNamespace(pipeline="springs"), per_dev, chunk) == springs
    w = chunk_width(SimpleNamespace(pipeline="exact"), per_dev, chunk)
    assert w == exact and (w // LANES) & (w // LANES - 1) == 0      # still a power of two of vectors
