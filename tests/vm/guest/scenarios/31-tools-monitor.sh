# i2c-tools and python3-smbus(2) through `contego monitor` + `contego run --socket` (uid 1000).
MODE=monitor
. /vm/inc/tools.sh
