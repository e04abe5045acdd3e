#!/usr/bin/env python3
"""Installs the npm packages of tests/node/package-lock.json into
tests/node/node_modules without npm: each locked tarball is fetched from its
`resolved` URL, checked against its `integrity` hash (from the npm registry when the lock names no URL), and unpacked.

CI needs Node.js to run the Khronos glTF validator, but Debian's npm
package is 357 packages; the validator is one tarball with no
dependencies. `npm ci --prefix tests/node` does the same where npm exists.
"""
import base64
import hashlib
import io
import json
import pathlib
import shutil
import sys
import tarfile
import urllib.request

HERE = pathlib.Path(__file__).resolve().parent


def main() -> int:
    lock = json.loads((HERE / "package-lock.json").read_text())
    for path, entry in lock["packages"].items():
        if not path:
            continue
        algorithm, digest = entry["integrity"].split("-", 1)
        target = HERE / path
        stamp = target / ".integrity"
        if stamp.is_file() and stamp.read_text() == entry["integrity"]:
            continue
        name = path.split("node_modules/")[-1]
        url = entry.get("resolved") or (
            f"https://registry.npmjs.org/{name}/-/{name.split('/')[-1]}-{entry['version']}.tgz"
        )
        with urllib.request.urlopen(url, timeout=60) as r:
            data = r.read()
        actual = base64.b64encode(hashlib.new(algorithm, data).digest()).decode()
        if actual != digest:
            print(f"error: {url}: {algorithm} {actual}, lock says {digest}", file=sys.stderr)
            return 1
        if target.exists():
            shutil.rmtree(target)
        target.mkdir(parents=True)
        with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
            for member in tar.getmembers():
                name = pathlib.PurePosixPath(member.name)
                parts = name.parts[1:]  # npm tarballs hold package/…
                if not parts or ".." in parts or name.is_absolute() or not (member.isfile() or member.isdir()):
                    continue
                dest = target.joinpath(*parts)
                if member.isdir():
                    dest.mkdir(parents=True, exist_ok=True)
                    continue
                dest.parent.mkdir(parents=True, exist_ok=True)
                dest.write_bytes(tar.extractfile(member).read())
        stamp.write_text(entry["integrity"])
        print(f"installed {path} {entry.get('version', '')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
