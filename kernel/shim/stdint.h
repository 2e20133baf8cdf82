/* The core's C header (contego/core_c.h) includes <stdint.h> and <stddef.h>;
 * the kernel has neither: its own types stand in. */
#ifndef CONTEGO_KMOD_STDINT_H_
#define CONTEGO_KMOD_STDINT_H_
#include <linux/types.h>
#endif
