# The image runs the wheel, as a user's `pip install` would: the source tree stays in the
# build stage, so the image holds only what the package ships (app, renderer, their data).
FROM python:3.11-slim-bookworm AS build
WORKDIR /src
COPY . .
RUN pip install --no-cache-dir build && python -m build --wheel --outdir /dist

FROM python:3.11-slim-bookworm
RUN apt-get update && apt-get install -y --no-install-recommends libegl1 libgl1-mesa-dri libegl-mesa0 \
    && rm -rf /var/lib/apt/lists/*
COPY --from=build /dist/ /tmp/dist/
RUN pip install --no-cache-dir /tmp/dist/*.whl && rm -rf /tmp/dist
WORKDIR /srv/facepair
ENV FLASK_APP=app.web
EXPOSE 8000
# Timeouts, request limits and an access log without identifying values: app/web/serving.py.
CMD ["gunicorn", "-c", "python:app.web.serving", "--bind", "0.0.0.0:8000", "--workers", "3", "app.web:create_app()"]
