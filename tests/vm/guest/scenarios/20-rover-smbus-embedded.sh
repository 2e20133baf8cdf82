# policies/rover.policy, python3-smbus client, embedded monitor.
MODE=embedded LIB=smbus
. /vm/inc/rover.sh
