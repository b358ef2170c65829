#include "tools/eval/stability_study.h"
