# policies/arm.policy, monitor embedded in `contego run --policy` (as root).
MODE=embedded
. /vm/inc/arm.sh
