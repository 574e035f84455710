# Declarations for the optional compiled build of the blocks (Cython, ctrlblocks.compiled).
# Python never reads this file: the interpreted base.py is the reference.  Cython reads it
# next to base.py and makes Block an extension type; every attribute not declared here
# stays in the instance __dict__, so interpreted subclasses (PT1, ...) work unchanged.
# Block.out is not declared: GainSchedule makes it a property.
# tests/blocks/test_compiled.py keeps this file in step with base.py.

cdef class Block:
    cdef dict __dict__
    cdef public object error_id, _config
    cpdef _checked(self, prev, result)
    cpdef output_limits(self)

cpdef object as_input(object x)
