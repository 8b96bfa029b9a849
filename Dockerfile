# Regolith mission control: `regolith serve` on 0.0.0.0:8000, the database on the /data volume.
#   docker build -t regolith .
#   docker run -p 8000:8000 -v regolith-data:/data -e REGOLITH_TOKEN=<16+ chars> regolith
# Without REGOLITH_TOKEN a token is generated once into /data/operator-token (see the log).
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    REGOLITH_DATA_DIR=/data

WORKDIR /srv/regolith
# Dependencies first (cached while only the code changes), then the code.
COPY pyproject.toml README.md ./
COPY engine ./engine
COPY experiments ./experiments
COPY app ./app
# The experiments extra (matplotlib, Dask) too: the server starts sweeps; and PostgreSQL's
# driver, for REGOLITH_DB_URL=postgresql+psycopg://…
RUN pip install '.[experiments,postgresql]' \
    && useradd --system --uid 10001 --home-dir /srv/regolith regolith \
    && mkdir -p /data && chown regolith /data
# Found from the working directory at run time: migrations are applied at start.
COPY migrations ./migrations
COPY frontend ./frontend

USER regolith
VOLUME ["/data"]
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/api/health', timeout=4)"]
# The same two steps as `make run`: migrate, then serve.
CMD ["sh", "-c", "regolith db upgrade && exec regolith serve --host 0.0.0.0 --port 8000"]
