"""Example networks and modules for the operator terminal (operator_demo.yaml: a robot the terminal drives)."""
