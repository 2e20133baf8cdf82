# policies/arm.policy through `contego monitor` (own uid, sole owner of the adapter)
# and `contego run --socket` as uid 1000.
MODE=monitor
. /vm/inc/arm.sh
