# policies/rover.policy, python3-smbus2 client, monitor daemon + uid 1000.
MODE=monitor LIB=smbus2
. /vm/inc/rover.sh
