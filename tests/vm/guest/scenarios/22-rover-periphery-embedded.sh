# policies/rover.policy, python3-periphery client (I2C_RDWR), embedded monitor.
MODE=embedded LIB=periphery
. /vm/inc/rover.sh
