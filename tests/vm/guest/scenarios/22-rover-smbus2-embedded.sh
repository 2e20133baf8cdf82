# policies/rover.policy, python3-smbus2 client, embedded monitor.
MODE=embedded LIB=smbus2
. /vm/inc/rover.sh
