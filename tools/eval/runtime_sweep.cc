#include "tools/eval/runtime_sweep.h"
