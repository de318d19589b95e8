"""Plays the sanity baseline, but leaves hostile files in /output."""

import os
import runpy

os.symlink("/etc/passwd", "/output/world_model.json")
os.mkfifo("/output/pipe.json")
with open("/output/huge.bin", "wb") as f:
    f.write(b"\0" * (3 << 20))
try:
    runpy.run_path("/app/agent.py", run_name="__main__")
except SystemExit:
    pass
os.replace("/output/world_model.json", "/output/.model")  # the baseline wrote a real file
os.symlink("/etc/passwd", "/output/world_model.json")
