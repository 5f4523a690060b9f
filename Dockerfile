# rodfem in Docker: Debian's FEniCSx (DOLFINx 0.9.0 on Debian 13, 0.5.2 on 12), with the forms of
# every demo compiled when the image is built (a run starts warm).  From the checkout:
#
#   docker build -t rodfem .                                   # Debian 13; --build-arg DEBIAN=bookworm: 12
#   mkdir -p results
#   docker run --rm --user "$(id -u):$(id -g)" -v "$PWD/results:/rodfem/results" rodfem
#       -> results/flying-spaghetti-2d/, owned by you
#   docker run --rm rodfem rodfem list
#   docker run --rm --user "$(id -u):$(id -g)" -v "$PWD/results:/rodfem/results" rodfem \
#       mpirun -n 2 rodfem run roll-up-2d --out results/roll-up-2d
#
# Without --user the container runs as root: files in results/ are root's, and mpirun needs
# --allow-run-as-root.  The JIT cache (/rodfem/.cache) is writable by any user, so forms a run
# changes (another integrator, an edited material) compile there.
ARG DEBIAN=trixie
FROM debian:${DEBIAN}
ENV DEBIAN_FRONTEND=noninteractive OMP_NUM_THREADS=1 \
    XDG_CACHE_HOME=/rodfem/.cache MPLCONFIGDIR=/tmp/matplotlib HOME=/tmp
WORKDIR /rodfem
COPY pyproject.toml README.md ./
COPY scripts ./scripts
COPY rodfem ./rodfem
COPY forms ./forms
COPY demos ./demos
COPY tests ./tests
RUN scripts/install-deps \
 && .venv/bin/python scripts/warm-forms \
 && apt-get clean && rm -rf /var/lib/apt/lists/* /usr/share/doc/* /usr/share/man/* /tmp/* /root/.cache \
 && mkdir -p results && chmod -R a+rwX /rodfem/.cache /rodfem/results
ENV PATH=/rodfem/.venv/bin:$PATH
CMD ["rodfem", "run", "flying-spaghetti-2d", "--out", "results/flying-spaghetti-2d", "--quiet"]
