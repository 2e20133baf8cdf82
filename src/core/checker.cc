// Placeholder so the skeleton builds; the core implementation replaces it.
#include "contego/core/checker.h"
