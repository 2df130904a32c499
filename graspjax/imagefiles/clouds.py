"""Organised point clouds, PCL's `.pcd` and the PLY range grid: the points (H, W, 3) in the
camera frame.

A `.pcd` file (PCL's Point Cloud Data, version 0.7) is a text header (`FIELDS`, `SIZE`,
`TYPE`, `COUNT`, `WIDTH`, `HEIGHT`, `POINTS`, `DATA`) followed by the points in one of three
encodings: `ascii` (a line per point), `binary` (one packed record per point) or
`binary_compressed` (the fields one after another, each for every point, the whole LZF
compressed). An RGB-D driver or `pcl_ros` writes a camera's cloud organised: `HEIGHT` rows of
`WIDTH` points, a point per pixel, NaN where the sensor saw nothing. Only such a cloud is a
depth image; an unorganised one (`HEIGHT` 1) is refused.

A `.ply` file (Stanford's polygon format) is organised when its header gives the grid as
`obj_info num_cols W` and `obj_info num_rows H` (as PCL's PLY writer does for an organised
cloud, Stanford's range scans before it), or a `camera` element gives it as `viewportx` and
`viewporty` (PCL's writer with its camera): either an element `range_grid` of W x H entries,
each a list of the one vertex seen at that pixel or of none, or a `vertex` element of exactly
W x H points in row order. Anything else (an unorganised cloud, a mesh) is refused. Every problem
raises `InputError`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from graspjax.errors import InputError

#: PCD's `TYPE` letter and `SIZE` in bytes -> the NumPy type of one value.
_TYPES = {("F", 4): "f4", ("F", 8): "f8", ("I", 1): "i1", ("I", 2): "i2", ("I", 4): "i4",
          ("I", 8): "i8", ("U", 1): "u1", ("U", 2): "u2", ("U", 4): "u4", ("U", 8): "u8"}
_HEADER_KEYS = ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT",
                "POINTS", "DATA")
#: The longest header a file may have before `DATA` (a PCD header is a dozen short lines).
_MAX_HEADER_BYTES = 1 << 16


def lzf_decompress(data: bytes, size: int) -> bytes:
    """The `size` bytes that liblzf's compressor turned into `data`.

    The stream is a series of runs, each opened by a control byte `c`: below 32, the next
    `c + 1` bytes are literal; otherwise a copy of `(c >> 5) + 2` bytes (the length 7 + 2 says
    that one more byte adds to it) from `((c & 31) << 8) + next byte + 1` bytes back in the
    output, which may overlap what it writes. Raises `ValueError` on a stream that does not
    decode to exactly `size` bytes."""
    out = bytearray(size)
    ip = op = 0
    end = len(data)
    while ip < end:
        ctrl = data[ip]
        ip += 1
        if ctrl < 32:
            length = ctrl + 1
            if ip + length > end or op + length > size:
                raise ValueError("a literal run past the end")
            out[op:op + length] = data[ip:ip + length]
            ip += length
            op += length
            continue
        length = ctrl >> 5
        if length == 7:
            if ip >= end:
                raise ValueError("a truncated run length")
            length += data[ip]
            ip += 1
        if ip >= end:
            raise ValueError("a truncated back reference")
        ref = op - ((ctrl & 0x1F) << 8) - data[ip] - 1
        ip += 1
        length += 2
        if ref < 0 or op + length > size:
            raise ValueError("a back reference outside the output")
        if ref + length <= op:
            out[op:op + length] = out[ref:ref + length]
        else:  # overlapping: a repeated pattern, copied byte by byte
            for k in range(length):
                out[op + k] = out[ref + k]
        op += length
    if op != size:
        raise ValueError(f"decoded {op} bytes, the header says {size}")
    return bytes(out)


def _header(raw: bytes, path: Path) -> tuple[dict[str, list[str]], int]:
    """The header's entries (key -> its words) and the offset where the data begins."""
    fields: dict[str, list[str]] = {}
    offset = 0
    while offset < min(len(raw), _MAX_HEADER_BYTES):
        newline = raw.find(b"\n", offset)
        if newline < 0:
            break
        line = raw[offset:newline].decode("ascii", "replace").strip()
        offset = newline + 1
        if not line or line.startswith("#"):
            continue
        key, *words = line.split()
        if key.upper() not in _HEADER_KEYS:
            raise InputError(f"{path}: not a PCD header line: {line[:40]!r}")
        fields[key.upper()] = words
        if key.upper() == "DATA":
            return fields, offset
    raise InputError(f"{path}: no PCD header ending in a DATA line")


def _layout(fields: dict[str, list[str]], path: Path) -> tuple[np.dtype, int, int]:
    """One point's record type (named fields, each of its `COUNT`), and the cloud's width and
    height."""
    missing = [k for k in ("FIELDS", "SIZE", "TYPE", "WIDTH", "DATA") if k not in fields]
    if missing:
        raise InputError(f"{path}: the PCD header lacks {', '.join(missing)}")
    names = fields["FIELDS"]
    counts = fields.get("COUNT", ["1"] * len(names))
    if not len(names) == len(fields["SIZE"]) == len(fields["TYPE"]) == len(counts):
        raise InputError(f"{path}: FIELDS, SIZE, TYPE and COUNT differ in length")
    try:
        width = int(fields["WIDTH"][0])
        height = int(fields.get("HEIGHT", ["1"])[0])
        sizes, counts = [int(s) for s in fields["SIZE"]], [int(c) for c in counts]
    except (ValueError, IndexError):
        raise InputError(f"{path}: WIDTH, HEIGHT, SIZE and COUNT must be integers") from None
    parts = []
    for k, (name, size, kind, count) in enumerate(
            zip(names, sizes, fields["TYPE"], counts, strict=True)):
        code = _TYPES.get((kind.upper(), size))
        if code is None or count < 1:
            raise InputError(f"{path}: field {name!r} has an unknown TYPE {kind} of SIZE {size}")
        # padding fields are all named "_": each gets a name of its own
        parts.append((name if name != "_" else f"_{k}", "<" + code, (count,) if count > 1 else ()))
    if width < 1 or height < 1:
        raise InputError(f"{path}: WIDTH and HEIGHT must be at least 1, got {width} x {height}")
    return np.dtype(parts), width, height


def _points(raw: bytes, encoding: str, record: np.dtype, count: int, path: Path) -> np.ndarray:
    """The `count` points (records) of the data after the header, in the file's order."""
    if encoding == "ascii":
        try:
            values = np.loadtxt(raw.decode("ascii").splitlines(), dtype=np.float64, ndmin=2)
        except ValueError as exc:
            raise InputError(f"{path}: unreadable ASCII points: {str(exc).splitlines()[0]}") from None
        per_point = sum(max(1, int(np.prod(record[n].shape))) for n in record.names)
        if values.shape != (count, per_point):
            raise InputError(f"{path}: expected {count} lines of {per_point} values, got "
                             f"{values.shape[0]} of {values.shape[1]}")
        points = np.zeros(count, record)
        column = 0
        for name in record.names:
            width = max(1, int(np.prod(record[name].shape)))
            points[name] = values[:, column:column + width].reshape(points[name].shape)
            column += width
        return points
    if encoding == "binary":
        if len(raw) < count * record.itemsize:
            raise InputError(f"{path}: {len(raw)} bytes of points, {count} points need "
                             f"{count * record.itemsize}")
        return np.frombuffer(raw, record, count)
    if encoding == "binary_compressed":
        if len(raw) < 8:
            raise InputError(f"{path}: the compressed data lacks its sizes")
        packed, unpacked = (int(s) for s in np.frombuffer(raw[:8], "<u4"))
        if unpacked != count * record.itemsize or len(raw) < 8 + packed:
            raise InputError(f"{path}: compressed sizes {packed} -> {unpacked} do not match "
                             f"{count} points of {record.itemsize} bytes")
        try:
            flat = lzf_decompress(raw[8:8 + packed], unpacked)
        except ValueError as exc:
            raise InputError(f"{path}: corrupt LZF data ({exc})") from None
        points = np.zeros(count, record)  # each field stored whole, one after another
        offset = 0
        for name in record.names:
            field = record.fields[name][0]
            points[name] = np.frombuffer(flat, field, count, offset)
            offset += count * field.itemsize
        return points
    raise InputError(f"{path}: unknown PCD DATA encoding {encoding!r} (expected ascii, binary or "
                     "binary_compressed)")


def read_pcd_points(path: str | Path) -> np.ndarray:
    """Every field of every point of an organised `.pcd` file: a structured array (HEIGHT,
    WIDTH) of the file's records (a padding field `_` named `_K`, K its position). An
    unorganised cloud (`HEIGHT` 1) or a malformed file raises `InputError`."""
    path = Path(path)
    raw = path.read_bytes()
    fields, offset = _header(raw, path)
    record, width, height = _layout(fields, path)
    if height == 1:
        raise InputError(f"{path}: an unorganised point cloud ({width} points in one row); a "
                         "depth image needs the camera's organised cloud (HEIGHT rows of WIDTH)")
    encoding = fields["DATA"][0].lower() if fields["DATA"] else ""
    points = _points(raw[offset:], encoding, record, width * height, path)
    return points.reshape(height, width)


def read_pcd(path: str | Path) -> np.ndarray:
    """The organised cloud of a `.pcd` file: float32 (HEIGHT, WIDTH, 3), its x, y, z fields
    (metres, the camera frame as the driver wrote it), NaN where a point is missing.
    An unorganised cloud, one without x, y and z, or a malformed file raises `InputError`."""
    points = read_pcd_points(path)
    missing = [a for a in "xyz" if a not in points.dtype.names]
    if missing:
        raise InputError(f"{path}: the cloud has no {', '.join(missing)} field "
                         f"(it has: {', '.join(points.dtype.names)})")
    return np.stack([points[a].astype(np.float32) for a in "xyz"], axis=-1)


#: PLY's property types -> NumPy's (without the byte order).
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}
_PLY_ORDERS = {"ascii": "<", "binary_little_endian": "<", "binary_big_endian": ">"}


def _ply_header(raw: bytes, path: Path) -> tuple[str, dict[str, int], list, int]:
    """The format, the `obj_info` integers, the elements (name, count, [(property, type,
    list count type or None)]) in file order, and the offset where the data begins."""
    end = raw.find(b"end_header", 0, _MAX_HEADER_BYTES)
    if not raw.startswith(b"ply") or end < 0:
        raise InputError(f"{path}: not a PLY file (no 'ply' ... 'end_header' header)")
    newline = raw.find(b"\n", end)
    offset = len(raw) if newline < 0 else newline + 1
    form, info, elements = "", {}, []
    for line in raw[:end].decode("ascii", "replace").splitlines()[1:]:
        words = line.split()
        if not words or words[0] == "comment":
            continue
        try:
            if words[0] == "format":
                form = words[1]
            elif words[0] == "obj_info" and len(words) >= 3 and words[2].lstrip("-").isdigit():
                info[words[1]] = int(words[2])
            elif words[0] == "element":
                elements.append((words[1], int(words[2]), []))
            elif words[0] == "property" and words[1] == "list":
                elements[-1][2].append((words[4], _PLY_TYPES[words[3]], _PLY_TYPES[words[2]]))
            elif words[0] == "property":
                elements[-1][2].append((words[2], _PLY_TYPES[words[1]], None))
        except (IndexError, KeyError, ValueError):
            raise InputError(f"{path}: an unreadable PLY header line: {line[:40]!r}") from None
    if form not in _PLY_ORDERS:
        raise InputError(f"{path}: unknown PLY format {form!r} (expected ascii, "
                         "binary_little_endian or binary_big_endian)")
    return form, info, elements, offset


def _ply_elements(data: bytes, form: str, elements: list, path: Path) -> dict[str, object]:
    """Each element's entries: a structured array (count,) for fixed-size ones, a list of
    lists for `range_grid`, None for an empty element."""
    order, out = _PLY_ORDERS[form], {}
    words = iter(data.decode("ascii", "replace").split()) if form == "ascii" else None
    offset = 0
    for name, count, properties in elements:
        lists = [p for p in properties if p[2] is not None]
        if count == 0:
            out[name] = None
        elif not lists:
            record = np.dtype([(p, order + kind) for p, kind, _ in properties])
            if words is not None:
                values = [next(words) for _ in range(count * len(properties))]
                table = np.asarray(values, np.float64).reshape(count, len(properties))
                out[name] = np.zeros(count, record)
                for k, (p, _, _) in enumerate(properties):
                    out[name][p] = table[:, k]
            else:
                if offset + count * record.itemsize > len(data):
                    raise InputError(f"{path}: the PLY data ends inside element {name!r}")
                out[name] = np.frombuffer(data, record, count, offset)
                offset += count * record.itemsize
        elif name == "range_grid" and len(properties) == 1:
            _, kind, length = properties[0]
            entries = []
            for _ in range(count):
                if words is not None:
                    n = int(next(words))
                    entries.append([int(next(words)) for _ in range(n)])
                    continue
                n = int(np.frombuffer(data, order + length, 1, offset)[0])
                offset += np.dtype(length).itemsize
                entries.append(np.frombuffer(data, order + kind, n, offset).tolist())
                offset += n * np.dtype(kind).itemsize
            out[name] = entries
        else:
            raise InputError(f"{path}: element {name!r} holds lists (a mesh?); expected an "
                             "organised point cloud")
    return out


def read_ply(path: str | Path) -> np.ndarray:
    """The organised cloud of a `.ply` file: float32 (rows, columns, 3), its vertices' x, y, z
    at their pixels (a range grid's, or W x H vertices in row order), NaN where none. The grid
    is the header's `obj_info num_cols` and `num_rows`, or the `viewportx` and `viewporty` of a
    `camera` element (PCL's writer with its camera). A cloud without its grid, a mesh or a
    malformed file raises `InputError`."""
    path = Path(path)
    raw = path.read_bytes()
    form, info, elements, offset = _ply_header(raw, path)
    try:
        found = _ply_elements(raw[offset:], form, elements, path)
    except (StopIteration, ValueError, TypeError):
        raise InputError(f"{path}: the PLY data does not match its header") from None
    width, height = info.get("num_cols", 0), info.get("num_rows", 0)
    camera = found.get("camera")
    if not width and camera is not None and {"viewportx", "viewporty"} <= set(camera.dtype.names):
        width, height = int(camera["viewportx"][0]), int(camera["viewporty"][0])
    if width < 1 or height < 2:
        raise InputError(f"{path}: an unorganised point cloud (no 'obj_info num_cols' and "
                         "'num_rows', nor a camera's viewport, in its header); a depth image "
                         "needs the camera's organised cloud")
    vertex = found.get("vertex")
    if vertex is None or any(a not in vertex.dtype.names for a in "xyz"):
        raise InputError(f"{path}: no vertex element with x, y and z")
    xyz = np.stack([vertex[a].astype(np.float32) for a in "xyz"], -1)
    grid = found.get("range_grid")
    if grid is None:
        if len(xyz) != width * height:
            raise InputError(f"{path}: {len(xyz)} vertices and no range_grid for a {width} x "
                             f"{height} grid")
        return xyz.reshape(height, width, 3)
    if len(grid) != width * height:
        raise InputError(f"{path}: a range_grid of {len(grid)} entries for a {width} x "
                         f"{height} grid")
    index = np.array([entry[0] if entry else -1 for entry in grid])
    if index.max(initial=-1) >= len(xyz):
        raise InputError(f"{path}: the range_grid names a vertex past the {len(xyz)} there are")
    cloud = np.where((index >= 0)[:, None], xyz[np.maximum(index, 0)], np.float32(np.nan))
    return cloud.reshape(height, width, 3).astype(np.float32)
