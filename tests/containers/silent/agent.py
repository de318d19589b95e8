"""Never connects: it sleeps forever, spawning children that must die with it."""

import subprocess
import time

for _ in range(3):
    subprocess.Popen(["sleep", "3600"])
while True:
    time.sleep(3600)
