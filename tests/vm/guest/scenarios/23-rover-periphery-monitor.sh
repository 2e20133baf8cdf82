# policies/rover.policy, python3-periphery client (I2C_RDWR), monitor daemon + uid 1000.
MODE=monitor LIB=periphery
. /vm/inc/rover.sh
