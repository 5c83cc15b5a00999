"""Just enough TOML for the scenes vrsc.Scene writes: tables, arrays of tables, and values that
are booleans, numbers, strings, lists and inline tables."""

import json
import math
import numbers


def value(v, where):
    """``v`` as a TOML value; ``where`` names it in errors."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        f = float(v)
        if not math.isfinite(f):
            raise ValueError(f"{where} must be a finite number, not {f}")
        return repr(f)
    if isinstance(v, str):
        # A JSON string is a TOML basic string (the same escapes).
        return json.dumps(v)
    if isinstance(v, dict):
        items = ", ".join(f"{key(k)} = {value(x, f'{where}.{k}')}" for k, x in v.items())
        return "{ " + items + " }" if items else "{}"
    if hasattr(v, "tolist"):
        return value(v.tolist(), where)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(value(x, where) for x in v) + "]"
    raise TypeError(f"{where} must be a bool, number, string, list or dict, not {type(v).__name__}")


def key(k):
    if not isinstance(k, str):
        raise TypeError(f"a scene key must be a string, not {type(k).__name__}")
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k)


def table(header, entries):
    """``[header]`` (or ``[[header]]`` when ``header`` starts with ``[``) and its entries."""
    lines = [f"[{header}]"]
    lines += [f"{key(k)} = {value(v, f'{header.strip(chr(91) + chr(93))}.{k}')}" for k, v in entries.items() if v is not None]
    return "\n".join(lines) + "\n"
