# rodfem on Debian 13 with Debian's FEniCSx (DOLFINx 0.9.0); Debian 12 (DOLFINx 0.5.2) with
#   docker build --build-arg DEBIAN=bookworm -t rodfem .
#   docker build -t rodfem .
#   docker run --rm -v "$PWD/results:/rodfem/results" rodfem                       # flying spaghetti
#   docker run --rm rodfem rodfem list
#   docker run --rm rodfem mpirun --allow-run-as-root -n 2 rodfem run roll-up-2d --out results/r
ARG DEBIAN=trixie
FROM debian:${DEBIAN}
ENV DEBIAN_FRONTEND=noninteractive OMP_NUM_THREADS=1
WORKDIR /rodfem
COPY pyproject.toml README.md ./
COPY scripts ./scripts
COPY rodfem ./rodfem
COPY forms ./forms
COPY demos ./demos
COPY tests ./tests
RUN scripts/install-deps && rm -rf /var/lib/apt/lists/*
ENV PATH=/rodfem/.venv/bin:$PATH
CMD ["rodfem", "run", "flying-spaghetti-2d", "--out", "results/flying-spaghetti-2d", "--quiet"]
