"""Reading YAML with line marks and turning validation errors into ``file:line:col``
messages; shared by ESAIR MIN's board files and ESAIR STD's deployment files.
"""
