#!/usr/bin/env bash
# A real single-node Slurm on this machine, for the Slurm integration test
# (tests/slurm.rs) and for trying `--executor slurm` by hand.
#
#   scripts/slurm-local.sh up      install (Debian packages, once), start munged,
#                                  slurmctld and slurmd, wait until the node is idle;
#                                  prints `SLURM_CONF=<file>` as its last line
#   scripts/slurm-local.sh down    stop slurmd, slurmctld and (if `up` started it) munged
#                                  by the pids in their pid files
#   scripts/slurm-local.sh status  print whether the daemons run and the node's state
#
# Everything lives under $REPOSE_SLURM_DIR (default /tmp/repose-slurm): the
# configuration (pass it to Slurm's commands as SLURM_CONF=…; /etc/slurm is never
# touched, so a machine's own Slurm is left alone), state, spool, logs, pid files.
# `up` is idempotent: with the daemons already up it only checks the node.
# There is no systemd here: the daemons are started by hand and daemonize
# themselves. `down` never removes packages: libmunge2 is shared with the MPI
# stack (see ../shared/cluster/slurm-local.md for why and for what was measured).
#
# Exit codes: 0 ready/stopped; 3 Slurm cannot be installed here (not root, or no
# apt-get): the caller may skip; 1 anything else (a failed install or start is
# an error, never a skip).
set -euo pipefail

DIR="${REPOSE_SLURM_DIR:-/tmp/repose-slurm}"
CONF="$DIR/slurm.conf"
HOST="$(hostname -s)"

log() { echo "slurm-local: $*" >&2; }

pid_alive() { [[ -f "$1" ]] && kill -0 "$(cat "$1")" 2>/dev/null; }

install_packages() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
        && command -v sbatch >/dev/null && command -v munged >/dev/null; then
        return 0
    fi
    if [[ "$(id -u)" != 0 ]]; then
        log "cannot install Slurm: not root (install slurmctld slurmd slurm-client munge yourself)"
        exit 3
    fi
    if ! command -v apt-get >/dev/null; then
        log "cannot install Slurm: no apt-get on this machine"
        exit 3
    fi
    log "installing slurmctld slurmd slurm-client munge (Debian packages)"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >&2
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >&2
}

start_munge() {
    if munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
        return 0
    fi
    if [[ ! -f /etc/munge/munge.key ]]; then
        log "creating /etc/munge/munge.key"
        if command -v mungekey >/dev/null; then
            mungekey --create --keyfile=/etc/munge/munge.key
        else
            dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
        fi
    fi
    chown munge:munge /etc/munge/munge.key
    chmod 0400 /etc/munge/munge.key
    mkdir -p /run/munge /var/lib/munge /var/log/munge
    chown munge:munge /run/munge /var/lib/munge /var/log/munge
    chmod 0755 /run/munge
    runuser -u munge -- /usr/sbin/munged
    # `down` stops munged only if this script started it.
    mkdir -p "$DIR" && touch "$DIR/munged-started-here"
    for _ in $(seq 50); do
        if munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
            return 0
        fi
        sleep 0.1
    done
    log "munged did not start (see /var/log/munge/munged.log)"
    exit 1
}

write_conf() {
    mkdir -p "$DIR/state" "$DIR/spool" "$DIR/log"
    chown slurm:slurm "$DIR/state" "$DIR/log"
    if ! getent hosts "$HOST" >/dev/null; then
        log "adding $HOST to /etc/hosts"
        echo "127.0.0.1 $HOST" >>/etc/hosts
    fi
    # The node line as slurmd measures it (CPUs, sockets, cores, memory), minus
    # the uptime line it prints after it.
    local node
    node="$(slurmd -C | grep '^NodeName=')"
    cat >"$CONF.tmp" <<EOF
# Written by scripts/slurm-local.sh: a one-node cluster for tests.
ClusterName=repose-local
SlurmctldHost=$HOST
SlurmUser=slurm
AuthType=auth/munge
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
MailProg=/bin/true
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SchedulerParameters=bf_interval=1
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=600
$node State=UNKNOWN
PartitionName=debug Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF
    mv "$CONF.tmp" "$CONF"
}

wait_idle() {
    local state=""
    for _ in $(seq 150); do
        state="$(SLURM_CONF="$CONF" sinfo -h -o %t 2>/dev/null | head -1 || true)"
        case "$state" in
        idle | mix | alloc) return 0 ;;
        esac
        sleep 0.2
    done
    log "the node did not become idle (last state: '${state:-none}'); logs in $DIR/log"
    exit 1
}

up() {
    install_packages
    start_munge
    if pid_alive "$DIR/slurmctld.pid" && pid_alive "$DIR/slurmd.pid"; then
        wait_idle
        echo "SLURM_CONF=$CONF"
        return 0
    fi
    write_conf
    export SLURM_CONF="$CONF"
    # slurmctld as root: it switches to SlurmUser itself (through runuser it
    # cannot write its pid file).
    pid_alive "$DIR/slurmctld.pid" || slurmctld
    pid_alive "$DIR/slurmd.pid" || slurmd
    wait_idle
    log "ready: one node ($HOST), configuration $CONF"
    echo "SLURM_CONF=$CONF"
}

down() {
    local name
    for name in slurmd slurmctld; do
        if pid_alive "$DIR/$name.pid"; then
            kill "$(cat "$DIR/$name.pid")"
        fi
    done
    if [[ -f "$DIR/munged-started-here" && -f /run/munge/munged.pid ]] \
        && kill -0 "$(cat /run/munge/munged.pid)" 2>/dev/null; then
        kill "$(cat /run/munge/munged.pid)"
        rm -f "$DIR/munged-started-here"
    fi
    log "stopped"
}

status() {
    local name
    for name in slurmctld slurmd; do
        if pid_alive "$DIR/$name.pid"; then echo "$name: running"; else echo "$name: stopped"; fi
    done
    if [[ -f "$CONF" ]]; then
        echo "node: $(SLURM_CONF="$CONF" sinfo -h -o %t 2>/dev/null || echo unknown)"
    fi
}

case "${1:-}" in
up) up ;;
down) down ;;
status) status ;;
*)
    echo "usage: $0 up|down|status" >&2
    exit 2
    ;;
esac
