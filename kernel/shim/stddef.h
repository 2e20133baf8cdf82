/* See stdint.h: the kernel's own definitions stand in. */
#ifndef CONTEGO_KMOD_STDDEF_H_
#define CONTEGO_KMOD_STDDEF_H_
#include <linux/stddef.h>
#include <linux/types.h>
#endif
