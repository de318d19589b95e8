"""``python -m schemas``: regenerate the JSON Schema files."""

from schemas._generate import write

for path in write():
    print(path)
