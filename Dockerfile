# spherefit HTTP service: multi-stage build, slim non-root runtime.
#   docker build -t spherefit . && docker run -p 127.0.0.1:8080:8080 spherefit
# Limits and settings come from SPHEREFIT_* environment variables (see `spherefit serve --help`).

FROM rust:1.95-bookworm AS build
WORKDIR /src
COPY Cargo.toml Cargo.lock openapi.yaml ./
COPY src ./src
COPY benches ./benches
COPY examples ./examples
RUN cargo build --release --locked \
    && cp target/release/spherefit /usr/local/bin/spherefit

FROM debian:bookworm-slim
RUN useradd --system --uid 10001 --no-create-home --shell /usr/sbin/nologin spherefit
COPY --from=build /usr/local/bin/spherefit /usr/local/bin/spherefit
USER 10001
ENV SPHEREFIT_LOG_FORMAT=json
EXPOSE 8080
# No curl in the slim image: bash's /dev/tcp asks /health and looks for "ok".
HEALTHCHECK --interval=30s --timeout=5s --start-period=5s --retries=3 \
    CMD ["bash", "-c", "exec 3<>/dev/tcp/127.0.0.1/8080 && printf 'GET /health HTTP/1.0\\r\\n\\r\\n' >&3 && grep -q '\"status\":\"ok\"' <&3"]
ENTRYPOINT ["spherefit"]
CMD ["serve", "--addr", "0.0.0.0:8080"]
