FROM python:3.11-slim-bookworm
RUN apt-get update && apt-get install -y --no-install-recommends libegl1 libgl1-mesa-dri libegl-mesa0 \
    && rm -rf /var/lib/apt/lists/*
WORKDIR /srv/facepair
COPY . .
RUN pip install --no-cache-dir .
ENV FLASK_APP=app
EXPOSE 8000
CMD ["gunicorn", "--bind", "0.0.0.0:8000", "--workers", "3", "--threads", "4", "--worker-class", "gthread", "app:create_app()"]
