# Sourced by scripts/slurm-setup.sh and scripts/slurm-stop.sh: the daemons they start and stop
# are found by pid file, and a pid file names a daemon only while that process lives under
# the expected name (a stale file may name a reused pid).

# Is process $1 alive (exists and is not a zombie)?
alive() {
  local st
  st="$(sed 's/.*) //' "/proc/$1/stat" 2>/dev/null | cut -d' ' -f1)" || return 1
  [[ -n "$st" && "$st" != Z && "$st" != X ]]
}

# Prints the pid in pidfile $1 if that process is alive and its name starts with $2; fails
# otherwise.
pid_of() {
  local pidfile=$1 name=$2 pid
  [[ -r "$pidfile" ]] || return 1
  pid="$(cat "$pidfile" 2>/dev/null)" || return 1
  [[ "$pid" =~ ^[0-9]+$ ]] && alive "$pid" || return 1
  [[ "$(cat "/proc/$pid/comm" 2>/dev/null)" == "$name"* ]] || return 1
  echo "$pid"
}

# Is the process in pidfile $1 alive and called $2?
running() { pid_of "$1" "$2" >/dev/null; }
