# policies/rover.policy, python3-smbus client, monitor daemon + uid 1000.
MODE=monitor LIB=smbus
. /vm/inc/rover.sh
