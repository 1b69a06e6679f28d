#!/usr/bin/env bash
# Runs a command with a virtual X display of its own (Debian's Xvfb, 24-bit colour, as
# ParaView's OpenGL needs): starts Xvfb on a free display number, waits until it accepts
# connections, runs the command with DISPLAY set, stops Xvfb. Exits with the command's
# status. (xvfb-run -a can hand out a display before its server answers on a loaded
# machine.)
#   with_xvfb.sh COMMAND [ARGS...]
set -uo pipefail
command -v Xvfb >/dev/null || { echo "with_xvfb.sh: Xvfb is not installed (apt-get install xvfb)" >&2; exit 1; }
for attempt in 1 2 3 4 5; do
  display=$(( 100 + (RANDOM % 800) ))
  [[ -e /tmp/.X${display}-lock || -e /tmp/.X11-unix/X${display} ]] && continue
  Xvfb ":$display" -screen 0 1280x1024x24 -nolisten tcp -noreset >/dev/null 2>&1 &
  server=$!
  for _ in $(seq 1 100); do  # up to 20 s for the socket
    [[ -S /tmp/.X11-unix/X${display} ]] && break
    kill -0 "$server" 2>/dev/null || break
    sleep 0.2
  done
  if [[ -S /tmp/.X11-unix/X${display} ]] && kill -0 "$server" 2>/dev/null; then
    DISPLAY=":$display" "$@"
    status=$?
    kill "$server" 2>/dev/null
    wait "$server" 2>/dev/null
    exit "$status"
  fi
  kill "$server" 2>/dev/null
  wait "$server" 2>/dev/null
done
echo "with_xvfb.sh: could not start Xvfb" >&2
exit 1
