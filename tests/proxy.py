"""deploy/nginx.conf run on this machine: the same server block, pointed at a test server,
a test media folder and a free port, inside a main configuration of its own."""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def nginx_conf(folder: Path, *, upstream: str, media: Path, port: int) -> Path:
    """Write ``folder/nginx.conf`` and return it: deploy/nginx.conf with only the addresses
    changed (the app, the media volume, the port)."""
    server = (ROOT / "deploy" / "nginx.conf").read_text(encoding="utf-8")
    for old, new in (
        ("server web:8000;", f"server {upstream};"),
        ("alias /srv/media/;", f"alias {media.resolve()}/;"),
        ("listen 80;", f"listen 127.0.0.1:{port};"),
        (
            "access_log /var/log/nginx/access.log facepair_private;",
            f"access_log {folder / 'access.log'} facepair_private;",
        ),
        ("error_log /var/log/nginx/error.log emerg;", f"error_log {folder / 'error.log'} emerg;"),
    ):
        assert old in server, old
        server = server.replace(old, new)
    temp = folder / "temp"
    temp.mkdir(parents=True, exist_ok=True)
    # as root the workers would drop to nobody and could not read a test's private folder
    user = "user root;\n" if os.geteuid() == 0 else ""
    conf = folder / "nginx.conf"
    conf.write_text(
        f"{user}worker_processes 1;\npid {folder / 'nginx.pid'};\n"
        f"error_log {folder / 'error.log'} warn;\nevents {{ worker_connections 64; }}\n"
        "http {\n    include /etc/nginx/mime.types;\n    access_log off;\n"
        + "".join(
            f"    {kind}_temp_path {temp / kind};\n"
            for kind in ("client_body", "proxy", "fastcgi", "uwsgi", "scgi")
        )
        + server
        + "\n}\n",
        encoding="utf-8",
    )
    return conf
