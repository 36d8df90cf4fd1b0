"""What the web application stands on: experimenter accounts and their sessions, limits of
stored values, security settings and headers, the media folders, and media delivery (Flask, a
front proxy or a bucket)."""
