"""The FMU archive: read its members, and write them deterministically (sorted names, one fixed date, 0755 for
shared libraries, 0644 for the rest, deflated) and atomically (a temporary file replaced at the end), so that two
builds of the same model give the same bytes and a failed build never leaves half an FMU."""
from __future__ import annotations

import zipfile
from pathlib import Path

#: every member's modification date (zip's epoch is 1980; a fixed date keeps builds byte-identical)
FIXED_DATE = (2020, 1, 1, 0, 0, 0)


def read_members(fmu) -> dict[str, bytes]:
    """{member name: bytes} of the archive ``fmu``."""
    with zipfile.ZipFile(fmu) as zf:
        return {info.filename: zf.read(info) for info in zf.infolist()}


def write_members(fmu, members: dict[str, bytes]) -> Path:
    """Write ``members`` as the archive ``fmu`` (replacing it), deterministically and atomically."""
    fmu = Path(fmu)
    partial = fmu.with_name(fmu.name + ".tmp")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, data in sorted(members.items()):
            entry = zipfile.ZipInfo(name, date_time=FIXED_DATE)
            entry.compress_type = zipfile.ZIP_DEFLATED
            entry.external_attr = (0o755 if name.endswith((".so", ".dll", ".dylib")) else 0o644) << 16
            zf.writestr(entry, data)
    partial.replace(fmu)
    return fmu
