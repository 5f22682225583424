#!/usr/bin/env python3
"""Print the JSON schema of the fleet manager's API bodies (cart2d/fleet/views.py), which
`make ws-types` turns into the fleet page's types (web/src/generated/fleet.ts) with
json-schema-to-typescript."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from cart2d.fleet.views import json_schema

if __name__ == "__main__":
    print(json.dumps(json_schema(), indent=2))
