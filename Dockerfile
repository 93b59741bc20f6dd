# spherefit: the HTTP service and the batch commands in one slim, non-root image.
#   docker build -t spherefit .
#   docker run --rm -p 127.0.0.1:8080:8080 spherefit                        # the service
#   docker run --rm -i spherefit fit --tolerance-m 100 - < in.geojson > out.geojson   # a batch job
# Limits and settings come from SPHEREFIT_* environment variables (see `spherefit serve --help`).
# .dockerignore is an allow-list: the context holds only what this build reads.

FROM rust:1.95-bookworm AS build
WORKDIR /src
# The workspace manifest names the Python package, so cargo needs its manifest and sources to
# load the workspace (they are not built); the benches are declared targets and must exist.
# build.rs derives the JSON API definition (/openapi.json) from openapi.yaml.
COPY Cargo.toml Cargo.lock openapi.yaml build.rs ./
COPY python/Cargo.toml python/Cargo.toml
COPY python/src python/src
COPY benches/sphere.rs benches/beta.rs benches/compare.rs benches/
# The map page embeds these (src/service/page.rs).
COPY web web
COPY fixtures/us_mexico_border_natural_earth.geojson fixtures/gps_tracks_slovenia_gpxpy.geojson fixtures/
COPY src src
# No debug line tables and a stripped binary: 4x smaller, same code.
ENV CARGO_PROFILE_RELEASE_DEBUG=false \
    CARGO_PROFILE_RELEASE_STRIP=true
RUN cargo build --release --locked --bin spherefit \
    && cp target/release/spherefit /usr/local/bin/spherefit

FROM debian:bookworm-slim
# A fixed uid/gid so a mounted directory can be made writable for it (chown 10001:10001 dir),
# or run with --user "$(id -u):$(id -g)" to write as yourself.
RUN groupadd --system --gid 10001 spherefit \
    && useradd --system --uid 10001 --gid 10001 --no-create-home --shell /usr/sbin/nologin spherefit \
    && mkdir /data && chown 10001:10001 /data
COPY --from=build /usr/local/bin/spherefit /usr/local/bin/spherefit
USER 10001:10001
# Batch jobs read and write relative paths here (mount a volume on /data).
WORKDIR /data
ENV SPHEREFIT_LOG_FORMAT=json
EXPOSE 8080
# No curl in the slim image: bash's /dev/tcp asks /health and looks for "ok".
HEALTHCHECK --interval=30s --timeout=5s --start-period=5s --retries=3 \
    CMD ["bash", "-c", "exec 3<>/dev/tcp/127.0.0.1/8080 && printf 'GET /health HTTP/1.0\\r\\n\\r\\n' >&3 && grep -q '\"status\":\"ok\"' <&3"]
ENTRYPOINT ["spherefit"]
CMD ["serve", "--addr", "0.0.0.0:8080"]
