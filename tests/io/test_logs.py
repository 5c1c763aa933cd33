"""Thesis-format log files (cpgjax/io/logs.py): rows T X Y Z theta phi psi from t = 0, LogRate per second."""

import numpy as np
from simcases import box

from cpgjax.episode.batch import simulate
from cpgjax.io.logs import pose_rows, read_log, write_log


def test_log_rows_start_at_t0_on_the_exact_sample_times(tmp_path):
    m = box(z=0.5, log_rate=10, contact=False)
    r = simulate(m, np.zeros((m.n_ctrl, m.n_coeff)), time=1.0, record=True)
    path = tmp_path / "box.log"
    write_log(path, "object", "Box", "box.wl", "-", pose_rows(r["traj"], 0))
    text = path.read_text().splitlines()
    assert text[0] == "# Log file for object Box" and text[1] == "# box.wl -"
    rows = read_log(path)
    assert rows.shape == (11, 7)
    np.testing.assert_array_equal(rows[:, 0], np.round(np.arange(11) / 10, 6))   # 0.000000, 0.100000, ...
    assert rows[0, 3] == 0.5 and np.all(rows[0, 4:] == 0)                        # the initial pose
    assert np.all(np.diff(rows[:, 3]) < 0)                                        # falling
