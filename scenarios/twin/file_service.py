"""The controller's file service (RWS `fileservice/...`): files under the roots a client
may reach, `$HOME` and `$RAMDISK`, each a folder of the served controller's own. A path
that leaves its root (`..`, an absolute path, a link), an unknown root and an upload beyond
MAX_UPLOAD are refused."""

from __future__ import annotations

from pathlib import Path

from scenarios.twin.controller_errors import ControllerError, bad_request, forbidden, not_found

#: The roots a client may reach, and their folder names.
ROOTS = {"$HOME": "HOME", "$RAMDISK": "RAMDISK", "$TEMP": "TEMP"}
#: Largest file a client may upload [bytes] (a controller's mass memory is small).
MAX_UPLOAD = 16 * 1024 * 1024


class FileService:
    """Files under `folder`/HOME, /RAMDISK and /TEMP."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        for name in ROOTS.values():
            (self.folder / name).mkdir(parents=True, exist_ok=True)

    def resolve(self, path: str) -> Path:
        """The file a client's `path` (e.g. "$HOME/program.mod") names; ControllerError
        if it is outside the roots."""
        raw = path.replace("\\", "/")
        parts = tuple(p for p in raw.split("/") if p)
        if raw.startswith("/") or not parts or parts[0] not in ROOTS:
            roots = ", ".join(ROOTS)
            raise forbidden(f"{path!r}: not under a root the file service serves ({roots})")
        if any(p in ("..", ".") for p in parts[1:]):
            raise forbidden(f"{path!r}: '..' and '.' are not allowed in a path")
        root = (self.folder / ROOTS[parts[0]]).resolve()
        target = root.joinpath(*parts[1:])
        if target.resolve() != root and root not in target.resolve().parents:
            raise forbidden(f"{path!r}: leaves {parts[0]}")
        return target

    def write(self, path: str, data: bytes) -> Path:
        """Write a file whole (its folder made); refused beyond MAX_UPLOAD."""
        if len(data) > MAX_UPLOAD:
            raise too_large(len(data))
        target = self.resolve(path)
        if target.is_dir():
            raise bad_request(f"{path!r} is a folder")
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_name(target.name + ".part")
        partial.write_bytes(data)
        partial.replace(target)
        return target

    def read(self, path: str) -> bytes:
        target = self.resolve(path)
        if not target.is_file():
            raise not_found(f"{path!r}: no such file")
        return target.read_bytes()

    def listing(self, path: str) -> list[tuple[str, bool, int]]:
        """(name, is a folder, size [bytes]) of a folder's entries, sorted."""
        target = self.resolve(path)
        if not target.is_dir():
            raise not_found(f"{path!r}: no such folder")
        return [
            (p.name, p.is_dir(), p.stat().st_size if p.is_file() else 0)
            for p in sorted(target.iterdir())
            if not p.name.endswith(".part")
        ]

    def delete(self, path: str) -> None:
        target = self.resolve(path)
        if target.is_file():
            target.unlink()
        elif target.is_dir() and not any(target.iterdir()) and target != target.parent:
            target.rmdir()
        else:
            raise not_found(f"{path!r}: no such file (or a folder that is not empty)")


def too_large(size: int) -> ControllerError:
    return ControllerError(
        413, "too_large", f"{size} bytes: larger than the {MAX_UPLOAD} bytes a file may have"
    )
