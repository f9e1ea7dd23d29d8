#!/bin/bash
# edge_cpu.sh LOG OUT COMMAND: runs one ninja edge's COMMAND with /bin/sh and appends "<user+sys seconds><TAB><OUT>" to
# LOG: the CPU time of everything the command ran (compiler, archiver, linker, test discovery), which other jobs on the
# machine barely change, unlike its wall time. bench/build_time.py wrap puts it in front of every rule of a build folder.
out=${2%% *}
/bin/sh -c "$3"
rc=$?
# This shell's waited-for children, fields 16-17 of /proc/PID/stat, in clock ticks.
read -r -a stat </proc/$$/stat
ticks=$(getconf CLK_TCK)
awk -v t=$((stat[15] + stat[16])) -v hz="$ticks" -v o="$out" 'BEGIN { printf "%.2f\t%s\n", t / hz, o }' >>"$1"
exit $rc
