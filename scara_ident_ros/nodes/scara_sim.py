def main(args=None):
    print('hello')
