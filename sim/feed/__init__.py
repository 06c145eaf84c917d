"""One simulated robot's hardware served to a real ``robotd run`` in another process.

``python -m sim.feed SCENARIO --dir DIR`` builds the scenario's world and its first robot's
simulated devices (``sim.rig``), runs them against the wall clock, and serves them where a real
robot's drivers find real hardware: the motor board on a pseudo-terminal (its encoders turn with
the commanded wheels), the LD19 on another (its byte stream at line rate), the dock IR
receivers' edges, the BLE adverts and the HX711's conversions on named pipes
(``docking.ir_source``, ``ble.source``, ``hx711.source`` = ``"stream"``), the cameras as video
files (``camera.source``, ``qr_camera.source`` = ``"file"``: a still of what the line camera
sees at the start; the first customer's QR code held up). It writes ``DIR/robotd.toml`` for
``robotd run`` and
plays the scenario's script (people walking, staff), following the daemon's state through its
control socket. Used by ``bench/bench_cpu_budget.py`` (issue 31).
"""
