#include <mlayer/mlayer.h>
