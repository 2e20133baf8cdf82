# i2c-tools and python3-smbus(2) through `contego run --policy` (embedded monitor).
MODE=embedded
. /vm/inc/tools.sh
