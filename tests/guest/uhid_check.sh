#!/bin/sh
# Inside the QEMU guest (.ci/vcan-guest/run): start the uhid gateway bridge, run the standalone
# hidapi client against it, stop the bridge. $1 = the Python to use. Results in $VCAN_GUEST_OUT.
py=$1
out=${VCAN_GUEST_OUT:?}
ready=$TMPDIR/uhid-ready
t0=$(cut -d' ' -f1 /proc/uptime)
"$py" -m host.uhid_gateway --ready-file "$ready" --summary "$out/uhid-summary.json" > "$out/uhid-bridge.log" 2>&1 &
pid=$!
# the bridge's start (Python, imports, building the network) took 83-114 s in a loaded TCG guest
limit=$(echo "$t0" | awk '{print $1 + 420}')
while [ ! -s "$ready" ]; do
  if ! kill -0 $pid 2>/dev/null; then echo "uhid bridge exited early:"; cat "$out/uhid-bridge.log"; exit 3; fi
  if awk -v l="$limit" '{exit !($1 > l)}' /proc/uptime; then
    echo "uhid bridge not ready after 420 s:"; cat "$out/uhid-bridge.log"; kill $pid; exit 3
  fi
  sleep 0.5
done
t1=$(cut -d' ' -f1 /proc/uptime)
"$py" tests/guest/hid_client.py --json "$out/uhid-client.json"
rc=$?
t2=$(cut -d' ' -f1 /proc/uptime)
kill -INT $pid
wait $pid
brc=$?
echo "{\"bridge_start_s\": $(echo "$t1 $t0" | awk '{print $1-$2}'), \"client_s\": $(echo "$t2 $t1" | awk '{print $1-$2}'), \"bridge_exit\": $brc, \"client_exit\": $rc}" > "$out/uhid-times.json"
cat "$out/uhid-bridge.log"
[ $rc -eq 0 ] && [ $brc -eq 0 ]
