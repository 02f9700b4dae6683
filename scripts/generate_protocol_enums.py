"""Writes sc2jax/environment/interface/protocol_enums.py from s2clientprotocol's enums.

Run: PROTOCOL_BUFFERS_PYTHON_IMPLEMENTATION=python python scripts/generate_protocol_enums.py
(s2clientprotocol's generated modules need protobuf's pure-Python mode under protobuf >= 4.)
"""

import pathlib

from s2clientprotocol import error_pb2, sc2api_pb2

HEADER = '''"""SC2 API enums that observations report, from s2clientprotocol (generated).

Do not edit: `scripts/generate_protocol_enums.py` writes this file, so that importing
sc2jax never needs s2clientprotocol's generated protobuf modules.
"""

import enum
'''


def enum_source(name: str, doc: str, items) -> str:
    lines = [f"\n\nclass {name}(enum.IntEnum):", f'    """{doc}"""', ""]
    lines += [f"    {key} = {value}" for key, value in sorted(items, key=lambda kv: kv[1])]
    return "\n".join(lines)


def main() -> None:
    source = HEADER
    source += enum_source("ActionResult", "`error.proto` ActionResult, as in `action_result`.",
                          error_pb2.ActionResult.items())
    source += enum_source("Alert", "`sc2api.proto` Alert, as in `alerts`.",
                          sc2api_pb2.Alert.items())
    out = pathlib.Path(__file__).parent.parent / "sc2jax" / "environment" / "protocol_enums.py"
    out.write_text(source + "\n")


if __name__ == "__main__":
    main()
