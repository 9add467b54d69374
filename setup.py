"""ament_python package set-up: the same file serves ``colcon build`` and ``pip install``."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'scara_ident_ros'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        # parameter files, and the Foxglove (.json) and PlotJuggler (.xml) plot layouts
        (f'share/{PACKAGE}/config',
         sorted(glob('config/*.yaml') + glob('config/*.json') + glob('config/*.xml'))),
        (f'share/{PACKAGE}/launch', glob('launch/*.py')),
        (f'share/{PACKAGE}/urdf', glob('urdf/*.urdf')),
    ],
    package_data={PACKAGE: ['py.typed']},
    install_requires=['setuptools', 'numpy', 'pyyaml'],
    zip_safe=True,
    maintainer='scara_ident_ros developers',
    maintainer_email='dev@scara-ident.invalid',
    description='Online identification of SCARA inverse dynamics with FFMW/FFW/FFS networks',
    license='Apache-2.0',
    python_requires='>=3.10',
    entry_points={
        'console_scripts': [
            'scara_sim = scara_ident_ros.nodes.console_scripts:scara_sim',
            'robot_sim = scara_ident_ros.nodes.console_scripts:robot_sim',
            'identifier = scara_ident_ros.nodes.console_scripts:identifier',
            'recorder = scara_ident_ros.nodes.console_scripts:recorder',
            'player = scara_ident_ros.nodes.console_scripts:player',
            'excitation = scara_ident_ros.nodes.console_scripts:excitation',
            'scara-ident = scara_ident_ros.cli:main',
        ],
    },
)
